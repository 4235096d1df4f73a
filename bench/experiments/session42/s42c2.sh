#!/bin/bash
# Session 42, call 2: where the dense cluster's shares pay (branch dense-cluster42 at the commit
# with dense_shift). Three plugins, interleaved: A = the bundle (one block up to 2 048 particles,
# then clusters of 1 024 a block), B = one block up to 1 024, then clusters of 1 024 a block, C = one
# block up to 512, clusters of 512 a block up to 8 192, of 1 024 above.
#   bash bench/experiments/session42/s42c2.sh gpu-carry/b42b.tar.gz gpu-carry/varB.tar.xz gpu-carry/varC.tar.xz   carry: gpu-carry
# (Its plugin unpacking, rounds and error cases are call_lib.sh's `variant`, `rounds` and
# `errors_test` now, which took over those lines.)
source tools/gpu/call_lib.sh "${4:-s42c2}" "$1"
declare -A D=([A]=$B [B]=$(variant B "$2") [C]=$(variant C "$3"))
rounds "A B C" --sizes 512,1024,1280,1536,2048,3072,4096,8192,16384 --steps 200 --warmup 20
TEST_TIMEOUT=240 correction_tests B C
echo done t=$SECONDS >> $I; pack
