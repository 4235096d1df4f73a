#!/bin/bash
# Session 48, call 1: issue 20's rows on main 2fae18c (setup47 merged: the dense correction's
# set-up loads at once), as session 44's call 8: HOOMD-blue built on the host's cores while the
# whole CUDA suite runs (its first run on the merged code); HOOMD-blue's ABP + WCA row, flipflow's
# at 2^10, 2^14 and 2^20 right after, 2^20 after 3 000 steps, Carter side by side and the sweep row.
#   bash bench/experiments/session48/s48c1.sh gpu-carry/b48.tar.xz   carry: gpu-carry (the bundle,
#   hoomd-kit.tgz = ../shared/peers-gpu/hoomd as hoomd-kit/, peers-bundle.tar.gz = ../shared/peers-gpu/bundle)
source tools/gpu/call_lib.sh "${2:-s48c1}" "$1"
declare -A D=([main]=$B)
issue20_rows 1024,16384,1048576
echo done t=$SECONDS >> $I; pack
