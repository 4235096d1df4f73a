#!/bin/bash
# Session 47, call 14: branch setup47 (session 44's set-up loads at once, issued before the gate
# in one block and after it in a cluster) against main 213891e's plugin: the correction's six CUDA
# test executables and its error cases, then bench-abp at 256, 1 024, 4 096 and 16 384, five
# interleaved rounds of 400 steps.
#   bash bench/experiments/session47/s47l.sh gpu-carry/b47.tar.xz    carry: gpu-carry (b47, vsetup)
source tools/gpu/call_lib.sh s47l "$1"
declare -A D=([main]=$B)
D[setup]=$(variant setup gpu-carry/vsetup.tar.xz)
correction_tests setup
errors_test setup
ROUNDS=5 rounds "main setup" --sizes 256,1024,4096,16384 --steps 400 --warmup 20
echo done t=$SECONDS >> $I; pack
