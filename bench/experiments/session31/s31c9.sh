#!/bin/bash
# Session 31, call 9: clock64 links of one flip in Lawson's tail kernel's apply
# (lawson-apply-clocks.patch on main, plugin v31aclk) at 2^10, 2^14 and 2^16.
#   bash bench/experiments/session31/s31c9.sh gpu-carry/b31d.tar.gz
source tools/gpu/call_lib.sh c9 "$1"
tar -xzf gpu-carry/v31aclk.tgz -C /tmp
C=$(shadow aclk /tmp/v31aclk)
for n in 1024 16384 65536; do
  timeout 60 $C/bin/pipeline bench $C/pipelines/bench-abp.yaml --device cuda --sizes $n --steps 100 --warmup 200 > $O/aclk-$n.txt 2>&1
  step aclk-$n $?
done
echo done t=$SECONDS >> $I; pack
