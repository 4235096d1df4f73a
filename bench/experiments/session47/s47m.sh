#!/bin/bash
# Session 47, call 15: branch lazy47 (the dense kernel takes a moved particle's |d_v| root after
# the moves' barrier, not on the chain before it) against setup47's plugin (main a530f49's
# correction): the correction's six CUDA test executables and its error cases, then bench-abp at
# 256, 1 024, 4 096 and 16 384, five interleaved rounds of 400 steps.
#   bash bench/experiments/session47/s47m.sh gpu-carry/b47.tar.xz    carry: gpu-carry (b47, vsetup, vlazy)
source tools/gpu/call_lib.sh s47m "$1"
declare -A D=([main]=$B)
D[setup]=$(variant setup gpu-carry/vsetup.tar.xz)
D[lazy]=$(variant lazy gpu-carry/vlazy.tar.xz)
correction_tests lazy
errors_test lazy
ROUNDS=5 rounds "setup lazy" --sizes 256,1024,4096,16384 --steps 400 --warmup 20
echo done t=$SECONDS >> $I; pack
