#!/bin/bash
# Session 47, call 12: where Lawson's tail kernel (one block) spends its time, the floor of ~7 µs
# a step for ~20 flips (call 11): lawson-tail-clocks.patch sums block thread 0's clock64 spans
# (the programmatic wait, the set-up, round 0's marks, then each round's decisions, flips and next
# marks, the end) and prints their means at exit (FF_LCLK=1). bench-abp at 1 024 and 16 384,
# bench-hd07 at 16 384; main's bundle once beside it for the steps/s.
#   bash bench/experiments/session47/s47j.sh gpu-carry/b47.tar.xz    carry: gpu-carry (b47, vlclk)
source tools/gpu/call_lib.sh s47j "$1"
declare -A D=([main]=$B)
D[lclk]=$(variant lclk gpu-carry/vlclk.tar.xz)
for p in bench-abp:1024 bench-abp:16384 bench-hd07:16384; do
  f=${p%%:*}; n=${p##*:}
  FF_LCLK=1 timeout 120 "${D[lclk]}/bin/pipeline" bench "${D[lclk]}/pipelines/$f.yaml" --device cuda --sizes $n --steps 400 --warmup 20 > "$O/lclk-$f-$n.txt" 2>&1
  step lclk-$f-$n $?
  timeout 120 "$B/bin/pipeline" bench "$B/pipelines/$f.yaml" --device cuda --sizes $n --steps 400 --warmup 20 > "$O/main-$f-$n.txt" 2>&1
  step main-$f-$n $?
done
echo done t=$SECONDS >> $I; pack
