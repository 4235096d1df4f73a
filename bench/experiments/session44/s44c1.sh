#!/bin/bash
# Session 44, call 1: three overlap_correct plugin variants against main b15981f's bundle.
#   A (branch push44, 1st commit): the dense kernel's threads push their own edges within reach,
#     offsets held from the reach test (no listing, no block barrier between test and pushes)
#   B (push44, 2nd commit): A with the push loop reading the ends' positions again (no spills)
#   C (main + kDenseMaxN 512): 1 024 particles on a cluster of 4 blocks of 256, not one block
# The correction's CUDA tests and error cases on each, then bench-abp at 1 024, 4 096 and 16 384,
# three interleaved rounds.
#   bash bench/experiments/session44/s44c1.sh gpu-carry/b44.tar.xz    carry: gpu-carry
source tools/gpu/call_lib.sh s44c1 "$1"
declare -A D=([main]=$B [A]=$(variant A gpu-carry/vA.tar.xz) [B]=$(variant B gpu-carry/vB.tar.xz) [C]=$(variant C gpu-carry/vC.tar.xz))
correction_tests A B C
for v in A B C; do errors_test $v; mv "$O/errors.txt" "$O/errors-$v.txt"; done
rounds "main A B C" --sizes 1024,4096,16384 --steps 200 --warmup 20
echo done t=$SECONDS >> $I; pack
