#!/bin/bash
# Session 46, call 2: overlap_correct plugin variant P (branch p2p46: the dense cluster's barrier
# after the moves replaced by point-to-point flags between the blocks that read each other's
# positions or lists) against main 4f74f74's bundle: the correction's CUDA tests and error cases,
# then bench-abp at 1 024 to 16 384, three interleaved rounds.
#   bash bench/experiments/session46/s46b.sh gpu-carry/b46a.tar.xz    carry: gpu-carry (b46a, vP)
source tools/gpu/call_lib.sh s46b "$1"
declare -A D=([main]=$B [P]=$(variant P gpu-carry/vP.tar.xz))
correction_tests P
errors_test P
ROUNDS=3 rounds "main P" --sizes 1024,2048,4096,8192,16384 --steps 400 --warmup 20
echo done t=$SECONDS >> $I; pack
