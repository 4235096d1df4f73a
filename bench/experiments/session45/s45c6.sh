#!/bin/bash
# Session 45, call 6: launch_cost.cu (what a launch and a captured graph of four kernels cost the
# host on this machine), then call_lib.sh's host_waits (tools/gpu/host_waits.c, moved there after
# calls 4-5) at 2^10 and 2^20.
#   bash bench/experiments/session45/s45c6.sh gpu-carry/b45n.tar.xz    carry: gpu-carry (b45n)
source tools/gpu/call_lib.sh s45c6 "$1"
nvcc -O2 -arch=sm_90 bench/experiments/session45/launch_cost.cu -o /tmp/launch_cost > $O/launch-cost.txt 2>&1
/tmp/launch_cost >> $O/launch-cost.txt 2>&1
step launch-cost $?
host_waits 1024 1048576
echo done t=$SECONDS >> $I; pack
