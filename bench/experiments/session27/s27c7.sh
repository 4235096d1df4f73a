#!/bin/bash
# Session 27, call 7 (bundle of e92304d: block_sum applied, 91a327c):
#   1. the whole CUDA suite on it;
#   2. where an iteration's time goes: overlap-iteration-clocks.patch's plugin (HEAD plus clock64
#      per phase, printed for launches 150-155 by block 0 and block 1's thread 0), bench-abp at
#      2^10, 2^12 and 2^14, one size a process; HEAD's own bench at the same sizes beside it in
#      time (one after the other), for reference.
#   bash bench/experiments/session27/s27c7.sh BUNDLE.tar.gz      carry: the bundle, v27clk
source tools/gpu/call_lib.sh c7 "$1"
tar -xzf gpu-carry/v27clk.tgz -C /tmp
declare -A D=([head]=$B [clk]=$(shadow clk /tmp/v27clk))
suite $B
step suite 0
for n in 1024 4096 16384; do
  timeout 60 ${D[clk]}/bin/pipeline bench ${D[clk]}/pipelines/bench-abp.yaml --device cuda --sizes $n --steps 200 --warmup 20 \
    > $O/clk-$n.txt 2>&1
  step clk-$n $?
  bench_abp head n$n --sizes $n --steps 200 --warmup 20
done
echo done t=$SECONDS >> $I; pack
