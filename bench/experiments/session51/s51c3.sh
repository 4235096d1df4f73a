#!/bin/bash
# Session 51, call 3: the phases of a late round (branch late51clk, second commit: lane 0 of each
# warp with a particle to gather, its first round's loads + pair math + sums, then finish + move
# + stores, then its later rounds, then the barrier and the decision; FF_LCLK=1), bench-abp 1 024.
#   bash bench/experiments/session51/s51c3.sh gpu-carry/bL51.tar.xz
#   carry: gpu-carry/bL51.tar.xz, gpu-carry/vlph.tar.xz
source tools/gpu/call_lib.sh s51c3 "$1"
declare -A D=([late]=$B)
D[lph]=$(variant lph gpu-carry/vlph.tar.xz)
FF_LCLK=1 timeout 120 "${D[lph]}/bin/pipeline" bench "${D[lph]}/pipelines/bench-abp.yaml" --device cuda --sizes 1024 --steps 400 --warmup 20 > "$O/lph-1024.txt" 2>&1
step lph-1024 $?
echo done t=$SECONDS >> $I; pack
