#!/bin/bash
# Session 47, call 1: where the one-block dense correction's time goes, iteration by iteration, at
# 1 024 particles (bench-abp): the variant of dense-iteration-clocks.patch prints block 0's
# thread 0 clock64 after each of an iteration's three barriers, the edges listed and the
# particles touched, for launches 300-339; main's bundle alone beside it for the steps/s.
#   bash bench/experiments/session47/s47a.sh gpu-carry/b47.tar.xz    carry: gpu-carry (b47, vclk)
source tools/gpu/call_lib.sh s47a "$1"
declare -A D=([main]=$B)
D[clk]=$(variant clk gpu-carry/vclk.tar.xz)
timeout 120 "${D[clk]}/bin/pipeline" bench "${D[clk]}/pipelines/bench-abp.yaml" --device cuda --sizes 1024 --steps 400 --warmup 20 > "$O/clk-1024.txt" 2>&1
step clk 0
ROUNDS=3 rounds "main clk" --sizes 1024 --steps 400 --warmup 20
echo done t=$SECONDS >> $I; pack
