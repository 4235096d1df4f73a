#!/bin/bash
# Session 44, call 9: CUPTI timelines of bench-abp at 2^10 and 2^14 on main 3cd3b0e (reach44
# merged), then overlap_correct plugin variant J2 (branch setup44b: the dense kernel's set-up
# loads a thread's particle and its edges' records at once, after reading the gate; call 7's J read
# them before it) against main's: J2's correction CUDA tests and error cases, bench-abp at 1 024,
# 2 048 and 16 384, five interleaved rounds.
#   bash bench/experiments/session44/s44c9.sh gpu-carry/b44m.tar.xz    carry: gpu-carry (b44m, vJ2)
source tools/gpu/call_lib.sh s44c9 "$1"
declare -A D=([main]=$B [J2]=$(variant J2 gpu-carry/vJ2.tar.xz))
timelines 1024 16384
correction_tests J2
errors_test J2
ROUNDS=5 rounds "main J2" --sizes 1024,2048,16384 --steps 400 --warmup 20
echo done t=$SECONDS >> $I; pack
