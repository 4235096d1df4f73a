#!/bin/bash
# Session 23, call 3 (one H200): the rows call 2 measured while HOOMD-blue compiled on the same
# host's cores (the sweep and Carter's side by side drive the GPU from the host), again on an
# idle host: the 64-run sweep deciding on the device and on the host (interleaved), Carter side
# by side, and bench-abp at 2^20 after 3000 steps both ways.
#   carry: gpu-carry/<bundle>.tar.gz gpu-carry/peers-bundle.tar.gz
source tools/gpu/call_lib.sh c3 "$1"
P=$B/pipelines
sw() { rm -rf /tmp/sw; FLIPFLOW_DEVICE_DECISIONS=$1 timeout 60 $B/bin/pipeline sweep $P/bench-abp.yaml --device cuda --set system.N=16384 --set run.steps=5000 --replicas 64 --out /tmp/sw --concurrent 64 --in-process 2>&1 | tail -1 | sed "s/^/dd=$1: /" >> $O/sweep.txt; step sweep-dd$1 $?; }
sw 1; sw 0
mkdir -p /tmp/pb && tar -xzf gpu-carry/peers-bundle.tar.gz -C /tmp/pb
timeout 150 bash bench/carter_side_by_side.sh $B /tmp/pb/bundle $O/carter small > $O/carter-run.txt 2>&1; step carter $?
sw 0; sw 1
b() { local v=$1 tag=$2; shift 2
  FLIPFLOW_DEVICE_DECISIONS=$v timeout 90 $B/bin/pipeline bench $P/bench-abp.yaml --device cuda "$@" 2>&1 |
    grep -E "^[0-9]|decided_on_device|overlap_correct/iter" | sed "s/^/dd=$v $tag: /" >> $O/ab.txt; step dd$v-$tag $?; }
b 1 late --sizes 1048576 --steps 100 --warmup 3000
b 0 late --sizes 1048576 --steps 100 --warmup 3000
echo done t=$SECONDS >> $I; pack
