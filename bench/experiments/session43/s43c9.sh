#!/bin/bash
# Session 43, call 9: call_lib.sh's new `timelines` (the lines of s31c1 and s43c1 it took over)
# checked on the GPU: bench-abp's timeline at 2^10 on main's bundle.
#   bash bench/experiments/session43/s43c9.sh gpu-carry/b43b.tar.xz    carry: gpu-carry
source tools/gpu/call_lib.sh "${2:-s43c9}" "$1"
timelines 1024
echo done t=$SECONDS >> $I; pack
