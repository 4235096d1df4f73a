#!/bin/bash
# Session 44, call 6: ncu of the dense kernels with variant I (branch reach44's head: the reach
# tests without branches, their offsets listed, owner-free loads with three rounds) at 1 024 and
# 16 384 particles, as session 42's call 5 (every warp sampled), for where an iteration's time is now.
#   bash bench/experiments/session44/s44c6.sh gpu-carry/b44.tar.xz    carry: gpu-carry (b44, vI)
source tools/gpu/call_lib.sh s44c6 "$1"
declare -A D=([main]=$B [I]=$(variant I gpu-carry/vI.tar.xz))
B=${D[I]} NCU_KERNEL=dense_kernel NCU_EXTRA="--warp-sampling-interval 0" ncu_correction 1024 16384
echo done t=$SECONDS >> $I; pack
