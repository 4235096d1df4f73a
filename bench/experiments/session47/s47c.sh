#!/bin/bash
# Session 47, call 3: where the one-block dense correction's time goes by iteration, without
# printf (call 1's printf variant ran at 12 500 steps/s against 20 400): the variant of
# dense-iteration-clocks.patch sums block thread 0's clock64 spans of each iteration's reach test,
# pushes and moves by iteration index and prints the means at exit (FF_DCLK=1); bench-abp at 256
# and 1 024, then two interleaved rounds against main's plugin for the instrumentation's cost.
#   bash bench/experiments/session47/s47c.sh gpu-carry/b47.tar.xz    carry: gpu-carry (b47, vclk2)
source tools/gpu/call_lib.sh s47c "$1"
declare -A D=([main]=$B)
D[clk]=$(variant clk gpu-carry/vclk2.tar.xz)
for n in 256 1024; do
  FF_DCLK=1 timeout 120 "${D[clk]}/bin/pipeline" bench "${D[clk]}/pipelines/bench-abp.yaml" --device cuda --sizes $n --steps 400 --warmup 20 > "$O/clk-$n.txt" 2>&1
  step clk-$n $?
done
ROUNDS=2 rounds "main clk" --sizes 256,1024 --steps 400 --warmup 20
echo done t=$SECONDS >> $I; pack
