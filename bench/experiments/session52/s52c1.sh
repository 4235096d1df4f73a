#!/bin/bash
# Session 52, call 1: issue 20's rows in one lease on main b4cdf29 (the code of session 49's call 3;
# since then only test_overlap_correct_cpu_cuda's new cases): the whole CUDA suite while HOOMD-blue
# builds, HOOMD-blue's ABP + WCA row, bench-abp at 2^10, 2^14, 2^20 and 2^20 after 3 000 steps,
# Carter side by side, the sweep row: the state the issue is left in.
#   bash bench/experiments/session52/s52c1.sh gpu-carry/b52.tar.xz   carry: the bundle,
#   gpu-carry/hoomd-kit.tgz, gpu-carry/peers-bundle.tar.gz
source tools/gpu/call_lib.sh s52c1 "$1"
declare -A D=([main]=$B)
issue20_rows 1024,16384,1048576
echo done t=$SECONDS >> $I; pack
