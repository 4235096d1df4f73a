#!/bin/bash
# Session 44, call 2: overlap_correct plugin variant D (branch reach44: the dense kernel's reach
# tests without branches so a thread's three edges overlap, a warp's listing with one atomic add)
# against main b15981f's bundle: the correction's CUDA tests and error cases, then bench-abp at
# 1 024 to 16 384, five interleaved rounds.
#   bash bench/experiments/session44/s44c2.sh gpu-carry/b44.tar.xz    carry: gpu-carry (b44, vD)
source tools/gpu/call_lib.sh s44c2 "$1"
declare -A D=([main]=$B [D]=$(variant D gpu-carry/vD.tar.xz))
correction_tests D
errors_test D
ROUNDS=5 rounds "main D" --sizes 1024,2048,4096,8192,16384 --steps 400 --warmup 20
echo done t=$SECONDS >> $I; pack
