#!/bin/bash
# Session 47, call 4: the one-block dense correction's reach test skipping warps whose edges have
# no end the last iteration touched (branch skip47), and the same with session 44's set-up loads at
# once (skipj47), against main 213891e's plugin: the correction's six CUDA test executables on
# both variants and its error cases on skip, then bench-abp at 256, 1 024 (one block) and 4 096 (a
# cluster), three interleaved rounds of 400 steps.
#   bash bench/experiments/session47/s47d.sh gpu-carry/b47.tar.xz    carry: gpu-carry (b47, vskip, vskipj)
source tools/gpu/call_lib.sh s47d "$1"
declare -A D=([main]=$B)
D[skip]=$(variant skip gpu-carry/vskip.tar.xz)
D[skipj]=$(variant skipj gpu-carry/vskipj.tar.xz)
correction_tests skip skipj
errors_test skip
ROUNDS=3 rounds "main skip skipj" --sizes 256,1024,4096 --steps 400 --warmup 20
echo done t=$SECONDS >> $I; pack
