#!/bin/bash
# Session 30, call 13: dtail30's launch failure under compute-sanitizer (bench-abp 2^10, a few steps).
#   bash bench/experiments/session30/s30c13.sh gpu-carry/b30h.tar.gz    carry: the bundle
source tools/gpu/call_lib.sh c13 "$1"
CS=$(command -v compute-sanitizer || ls /usr/local/cuda*/bin/compute-sanitizer 2>/dev/null | head -n 1)
echo "sanitizer: $CS" >> $I
timeout 150 $CS --print-limit 5 $B/bin/pipeline bench $B/pipelines/bench-abp.yaml --device cuda --sizes 1024 --steps 2 --warmup 30 > $O/cs.txt 2>&1
step cs $?
echo done t=$SECONDS >> $I; pack
