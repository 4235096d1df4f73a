#!/bin/bash
# Session 49, call 3: issue 20's rows in one lease on main 97e61e4 (after_previous_kernel; the
# corrections' shared max_iterations advice): the whole CUDA suite while HOOMD-blue builds,
# HOOMD-blue's ABP + WCA row, bench-abp at 2^10, 2^14, 2^20 and 2^20 after 3 000 steps, Carter side by
# side, the sweep row.
#   bash bench/experiments/session49/s49c3.sh gpu-carry/b49f.tar.xz   carry: the bundle,
#   gpu-carry/hoomd-kit.tgz, gpu-carry/peers-bundle.tar.gz
source tools/gpu/call_lib.sh s49c3 "$1"
declare -A D=([main]=$B)
issue20_rows 1024,16384,1048576
echo done t=$SECONDS >> $I; pack
