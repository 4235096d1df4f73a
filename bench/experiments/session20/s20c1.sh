#!/bin/bash
# Session 20, call 1 (nvidia-h200-x2): (a) delaunay.flip's b8199dc on CUDA, (b) issue 21's
# multi-GPU cases (never run on several GPUs before), (c) weak scaling 1 -> 2 GPUs of the
# decomposed pipelines, (d) bench-abp on GPU 0. Logs under /tmp/c; $OUT/c.tgz remade after every part.
set -u
SECONDS=0
export NCCL_NVLS_ENABLE=0 TORCH_SYMM_MEM_DISABLE_MULTICAST=1 NVSHMEM_DISABLE_NVLS=1 NCCL_DEBUG=WARN
tar -xzf gpu-carry/bundle-s20.tar.gz
B=$PWD/bundle; O=/tmp/c; rm -rf $O; mkdir -p $O
I=$O/info.txt
for d in /usr/local/cuda/lib64 /usr/lib/x86_64-linux-gnu \
  $(python3 -c 'import nvidia.nccl, os; print(os.path.dirname(nvidia.nccl.__file__) + "/lib")' 2>/dev/null); do
  [[ -z ${FLIPFLOW_NCCL_LIBRARY:-} && -f $d/libnccl.so.2 ]] && export FLIPFLOW_NCCL_LIBRARY=$d/libnccl.so.2
done
{ nvidia-smi -L; nvidia-smi topo -m | head -6; echo "nccl=${FLIPFLOW_NCCL_LIBRARY:-loader}"; head -1 $B/.flipflow-bundle; } > $I 2>&1
pack() { (cd /tmp && tar -czf $OUT/c.tgz.part c && mv $OUT/c.tgz.part $OUT/c.tgz); }
step() { echo "$1 rc=$2 t=$SECONDS" >> $I; pack; }
(cd $B && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 150 bin/run-tests test_delaunay_flip test_boids_delaunay > $O/flip.txt 2>&1; echo rc=$? >> $O/flip.txt) &
(cd $B && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="*GPU*" timeout 200 bin/run-tests test_team test_decomposition test_decomposition_delaunay > $O/multi.txt 2>&1; echo rc=$? >> $O/multi.txt) &
wait; step tests 0
P=$B/pipelines; D=$B/tests/data
bench() { local tag=$1 lim=$2; shift 2; timeout $lim $B/bin/pipeline bench "$@" > $O/$tag.txt 2>&1; step $tag $?; }
bench abp-1 70 $P/bench-abp.yaml --device cuda --sizes 1048576 --steps 100 --warmup 20
bench abp-g2 90 $P/bench-abp.yaml --gpus 2 --sizes 2097152 --steps 100 --warmup 20
bench lj-1 50 $D/decomp-lj.yaml --gpus 1 --sizes 1048576 --steps 100 --warmup 20
bench lj-2 60 $D/decomp-lj.yaml --gpus 2 --sizes 2097152 --steps 100 --warmup 20
((SECONDS < 420)) && bench hs-1 50 $D/decomp-hard-spheres.yaml --gpus 1 --sizes 1048576 --steps 100 --warmup 20
((SECONDS < 480)) && bench hs-2 60 $D/decomp-hard-spheres.yaml --gpus 2 --sizes 2097152 --steps 100 --warmup 20
echo done t=$SECONDS >> $I; pack
