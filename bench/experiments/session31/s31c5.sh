#!/bin/bash
# Session 31, call 5: clock64 phases of Lawson's tail kernel (lawson-cluster-clocks.patch on
# lcl31) as a cluster of 16 (v31cc16), of 8 (v31cc8) and as one block at every size (v31cc1), at
# 2^14 and 2^16; then bench-abp of the three at 2^14 and 2^16.
#   bash bench/experiments/session31/s31c5.sh gpu-carry/b31c.tar.gz
source tools/gpu/call_lib.sh c5 "$1"
declare -A D=([cl]=$B)
for v in cc16 cc8 cc1; do
  tar -xzf gpu-carry/v31$v.tgz -C /tmp
  D[$v]=$(shadow $v /tmp/v31$v)
  for n in 16384 65536; do
    timeout 60 ${D[$v]}/bin/pipeline bench ${D[$v]}/pipelines/bench-abp.yaml --device cuda --sizes $n --steps 100 --warmup 100 > $O/clk-$v-$n.txt 2>&1
    step clk-$v-$n $?
  done
done
echo done t=$SECONDS >> $I; pack
