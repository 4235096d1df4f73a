#!/bin/bash
# Session 43, call 1: main 94fa9b3 (review42-closed-gate merged: report_closed_gate and in_block in
# overlap_correct's kernels, never GPU-run before): the whole CUDA suite, then CUPTI timelines of
# bench-abp at 2^10, 2^14 and 2^20 (session 31's call 1), the untraced bench beside them.
# (The timelines are call_lib.sh's `timelines` now, which took over these lines.)
#   bash bench/experiments/session43/s43c1.sh gpu-carry/b43a.tar.xz    carry: gpu-carry
source tools/gpu/call_lib.sh "${2:-s43c1}" "$1"
declare -A D=([main]=$B)
suite "$B" 280
step suite 0
bench_abp main rows --sizes 1024,16384 --steps 200 --warmup 20
bench_abp main big --sizes 1048576 --steps 100 --warmup 20
timelines 1024 16384 1048576
echo done t=$SECONDS >> $I; pack
