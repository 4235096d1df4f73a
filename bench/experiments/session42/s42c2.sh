#!/bin/bash
# Session 42, call 2: where the dense cluster's shares pay (branch dense-cluster42 at the commit
# with dense_shift). Three plugins, interleaved: A = the bundle (one block up to 2 048 particles,
# then clusters of 1 024 a block), B = one block up to 1 024, then clusters of 1 024 a block, C = one
# block up to 512, clusters of 512 a block up to 8 192, of 1 024 above.
#   bash bench/experiments/session42/s42c2.sh gpu-carry/b42b.tar.gz gpu-carry/varB.tar.xz gpu-carry/varC.tar.xz   carry: gpu-carry
source tools/gpu/call_lib.sh "${4:-s42c2}" "$1"
mkdir -p /tmp/pB /tmp/pC && tar -xJf "$2" -C /tmp/pB && tar -xJf "$3" -C /tmp/pC
declare -A D=([A]=$B [B]=$(shadow B /tmp/pB) [C]=$(shadow C /tmp/pC))
for r in 1 2 3; do for v in A B C; do bench_abp $v r$r --sizes 512,1024,1280,1536,2048,3072,4096,8192,16384 --steps 200 --warmup 20; done; done
TEST_TIMEOUT=240 correction_tests B C
echo done t=$SECONDS >> $I; pack
