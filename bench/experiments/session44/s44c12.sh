#!/bin/bash
# Session 44, call 12: overlap_correct plugin variant M (branch rows44: the dense kernels sum a
# launch's pairs and correction per thread and reduce them once, into its first row, instead of
# reducing them every iteration; the host sums the correction in fixed point) against main
# 3cd3b0e's bundle: the correction's CUDA tests and error cases, then bench-abp at 1 024 to
# 16 384, three interleaved rounds.
#   bash bench/experiments/session44/s44c12.sh gpu-carry/b44m.tar.xz    carry: gpu-carry (b44m, vM)
source tools/gpu/call_lib.sh s44c12 "$1"
declare -A D=([main]=$B [M]=$(variant M gpu-carry/vM.tar.xz))
correction_tests M
errors_test M
ROUNDS=3 rounds "main M" --sizes 1024,2048,4096,16384 --steps 400 --warmup 20
echo done t=$SECONDS >> $I; pack
