#!/bin/bash
# Session 43, call 8: issue 20's rows on main 38e13f2 (flipstore43 merged), as session 42's call 4:
# HOOMD-blue is built on the host's cores while the whole CUDA suite runs; then HOOMD-blue's ABP +
# WCA row, flipflow's at 2^10, 2^14 and 2^20 right after, 2^20 after 3 000 steps, Carter side by
# side and the sweep row.
#   bash bench/experiments/session43/s43c8.sh gpu-carry/b43b.tar.xz   carry: gpu-carry (the bundle,
#   hoomd-kit.tgz = ../shared/peers-gpu/hoomd as hoomd-kit/, peers-bundle.tar.gz = ../shared/peers-gpu/bundle)
# (The rows' steps are call_lib.sh's `issue20_rows` now, which took over these lines.)
source tools/gpu/call_lib.sh "${2:-s43c8}" "$1"
declare -A D=([main]=$B)
issue20_rows 1024,16384,1048576
echo done t=$SECONDS >> $I; pack
