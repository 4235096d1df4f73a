#!/bin/bash
# Session 31, call 1: main 61a8ccb (code of 713c209): CUPTI timelines of bench-abp at 2^10, 2^14,
# 2^16 and 2^20 (the timed back-to-back pass), to see where a step's time goes now, and the
# untraced bench beside them.
# (The timelines are call_lib.sh's `timelines` now, which took over these lines.)
#   bash bench/experiments/session31/s31c1.sh gpu-carry/b31a.tar.gz [NAME]    carry: the bundle
source tools/gpu/call_lib.sh "${2:-c1}" "$1"
declare -A D=([head]=$B)
bench_abp head small --sizes 1024,16384,65536 --steps 200 --warmup 20
bench_abp head big --sizes 1048576 --steps 100 --warmup 20
timelines 1024 16384 65536 1048576
echo done t=$SECONDS >> $I; pack
