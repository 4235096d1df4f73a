#!/bin/bash
# Session 44, call 8: issue 20's rows on main 3cd3b0e (reach44 merged: the dense kernel's
# branch-free reach tests and listed offsets), as session 43's call 8: HOOMD-blue built on the
# host's cores while the whole CUDA suite runs; HOOMD-blue's ABP + WCA row, flipflow's at 2^10,
# 2^14 and 2^20 right after, 2^20 after 3 000 steps, Carter side by side and the sweep row.
#   bash bench/experiments/session44/s44c8.sh gpu-carry/b44m.tar.xz   carry: gpu-carry (the bundle,
#   hoomd-kit.tgz = ../shared/peers-gpu/hoomd as hoomd-kit/, peers-bundle.tar.gz = ../shared/peers-gpu/bundle)
source tools/gpu/call_lib.sh "${2:-s44c8}" "$1"
declare -A D=([main]=$B)
issue20_rows 1024,16384,1048576
echo done t=$SECONDS >> $I; pack
