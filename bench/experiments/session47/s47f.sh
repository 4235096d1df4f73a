#!/bin/bash
# Session 47, call 6: call 3's clocks (dense-iteration-clocks.patch) on skipc (skip47: the reach
# test skipping warps without a touched end, a thread's edges consecutive) and on main, to see
# which iterations the consecutive edges cost and which the skip saves: bench-abp at 1 024 with
# FF_DCLK=1 for each.
#   bash bench/experiments/session47/s47f.sh gpu-carry/b47.tar.xz    carry: gpu-carry (b47, vclkm, vclkc)
source tools/gpu/call_lib.sh s47f "$1"
declare -A D=([main]=$B)
D[clkm]=$(variant clkm gpu-carry/vclkm.tar.xz)
D[clkc]=$(variant clkc gpu-carry/vclkc.tar.xz)
for v in clkm clkc; do
  FF_DCLK=1 timeout 120 "${D[$v]}/bin/pipeline" bench "${D[$v]}/pipelines/bench-abp.yaml" --device cuda --sizes 1024 --steps 400 --warmup 20 > "$O/$v-1024.txt" 2>&1
  step $v $?
done
echo done t=$SECONDS >> $I; pack
