#!/bin/bash
# Session 51, call 2: where late51's time goes. Branch late51clk (block thread 0's clock64 by
# iteration of the one block's launches, late iterations' busiest-warp rounds and gathered
# particles, start_late's cycles; printed at exit with FF_LCLK=1) with kLateMoved 32 (lclk) and
# -1 (lclk0: never late, the edge pass's iterations under the same clocks), bench-abp 1 024 and 256.
#   bash bench/experiments/session51/s51c2.sh gpu-carry/bL51.tar.xz
#   carry: gpu-carry/bL51.tar.xz, gpu-carry/vlclk.tar.xz, gpu-carry/vlclk0.tar.xz
source tools/gpu/call_lib.sh s51c2 "$1"
declare -A D=([late]=$B)
D[lclk]=$(variant lclk gpu-carry/vlclk.tar.xz)
D[lclk0]=$(variant lclk0 gpu-carry/vlclk0.tar.xz)
for v in lclk lclk0; do for n in 1024 256; do
  FF_LCLK=1 timeout 120 "${D[$v]}/bin/pipeline" bench "${D[$v]}/pipelines/bench-abp.yaml" --device cuda --sizes $n --steps 400 --warmup 20 > "$O/$v-$n.txt" 2>&1
  step "$v-$n" $?
done; done
echo done t=$SECONDS >> $I; pack
