#!/bin/bash
# Session 44, call 3: overlap_correct plugin variant E (branch reach44: D with a cluster testing only the rounds its share fills; the dense kernel's reach
# tests without branches so a thread's three edges overlap, a warp's listing with one atomic add)
# against main b15981f's bundle: the correction's CUDA tests and error cases, then bench-abp at
# 256 to 16 384, five interleaved rounds.
#   bash bench/experiments/session44/s44c3.sh gpu-carry/b44.tar.xz    carry: gpu-carry (b44, vE)
source tools/gpu/call_lib.sh s44c3 "$1"
declare -A D=([main]=$B [E]=$(variant E gpu-carry/vE.tar.xz))
correction_tests E
errors_test E
ROUNDS=5 rounds "main E" --sizes 256,512,1024,2048,4096,8192,16384 --steps 400 --warmup 20
echo done t=$SECONDS >> $I; pack
