#!/bin/bash
# Session 20, call 2 (nvidia-h200-x2): octile3's request (tiled CUDA loop: bits, bench), then
# mgpu's (2-GPU hard spheres fix, device-side ghost traffic), then a 64-run sweep on GPU 0 alone.
set -u
SECONDS=0
export NCCL_NVLS_ENABLE=0 TORCH_SYMM_MEM_DISABLE_MULTICAST=1 NVSHMEM_DISABLE_NVLS=1
tar -xzf gpu-carry/bundle-s20.tar.gz
B=$PWD/bundle
nvidia-smi -L > $OUT/info.txt
timeout 200 bash gpu-carry/octile3/run.sh $B $OUT/oc > $OUT/oc-stdout.txt 2>&1; echo "octile3 rc=$? t=$SECONDS" >> $OUT/info.txt
timeout 200 bash gpu-carry/mgpu/run.sh $B $OUT/mg > $OUT/mg-stdout.txt 2>&1; echo "mgpu rc=$? t=$SECONDS" >> $OUT/info.txt
if ((SECONDS < 470)); then
  mkdir -p /tmp/sw
  (nproc; CUDA_VISIBLE_DEVICES=0 timeout 60 $B/bin/pipeline sweep $B/pipelines/bench-abp.yaml --device cuda --set system.N=16384 --set run.steps=5000 --replicas 64 --concurrent 64 --in-process --out /tmp/sw/runs 2>&1 | tail -5) > $OUT/sweep-gpu0.txt 2>&1
  echo "sweep rc=$? t=$SECONDS" >> $OUT/info.txt
fi
echo done t=$SECONDS >> $OUT/info.txt
