#!/bin/bash
# Session 20, call 4 (nvidia-h200-x2): mgpu's final request, octile3's request 3, the sweep cluster variants' bits.
set -u
SECONDS=0
export NCCL_NVLS_ENABLE=0 TORCH_SYMM_MEM_DISABLE_MULTICAST=1 NVSHMEM_DISABLE_NVLS=1
tar -xzf gpu-carry/bundle-s20.tar.gz
B=$PWD/bundle
nvidia-smi -L > $OUT/info.txt
timeout 100 bash gpu-carry/mgpu/final.sh $B /tmp/mg > $OUT/mg-stdout.txt 2>&1; echo "mgpu rc=$? t=$SECONDS" >> $OUT/info.txt
cp /tmp/mg/*.tgz $OUT/ 2>/dev/null
timeout 100 bash gpu-carry/octile3/run.sh $B /tmp/oc > $OUT/oc-stdout.txt 2>&1; echo "octile3 rc=$? t=$SECONDS" >> $OUT/info.txt
timeout 150 bash gpu-carry/sweepc/bits.sh $B /tmp/sw > $OUT/sweepc-stdout.txt 2>&1; echo "sweepc rc=$? t=$SECONDS" >> $OUT/info.txt
(cd /tmp && tar -czf $OUT/rest.tgz oc sw 2>/dev/null)
echo done t=$SECONDS >> $OUT/info.txt
