#!/bin/bash
# Session 31, call 2: clock64 phases of delaunay.lawson's tail kernel and detect_inversion's
# marking kernel (lawson-mark-clocks.patch, plugin v31clk) in bench-abp at 2^10, 2^14, 2^16.
#   bash bench/experiments/session31/s31c2.sh gpu-carry/b31a.tar.gz gpu-carry/v31clk.tgz
source tools/gpu/call_lib.sh c2 "$1"
tar -xzf "$2" -C /tmp
C=$(shadow clk /tmp/v31clk)
for n in 1024 16384 65536; do
  timeout 60 $C/bin/pipeline bench $C/pipelines/bench-abp.yaml --device cuda --sizes $n --steps 100 --warmup 100 > $O/clk-$n.txt 2>&1
  step clk-$n $?
done
echo done t=$SECONDS >> $I; pack
