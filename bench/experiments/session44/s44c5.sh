#!/bin/bash
# Session 44, call 5: overlap_correct plugin variant H (branch reachH44: G, and a cluster whose
# threads test more than one round reads the reach tests' positions through distributed shared
# memory without a branch on the owner, F's form) against G and main b15981f's bundle: the
# correction's CUDA tests and error cases on H, then bench-abp at 512 to 16 384, five interleaved
# rounds.
#   bash bench/experiments/session44/s44c5.sh gpu-carry/b44.tar.xz    carry: gpu-carry (b44, vG, vH)
source tools/gpu/call_lib.sh s44c5 "$1"
declare -A D=([main]=$B [G]=$(variant G gpu-carry/vG.tar.xz) [H]=$(variant H gpu-carry/vH.tar.xz))
correction_tests H
errors_test H
ROUNDS=5 rounds "main G H" --sizes 512,1024,2048,4096,8192,16384 --steps 400 --warmup 20
echo done t=$SECONDS >> $I; pack
