#!/bin/bash
# Session 42, call 4: issue 20's rows on branch dense-cluster42 (the dense cluster for runs alone of
# 1 025-16 384 particles; the dense kernels check records and make pushes through kernel.h's
# Overlaps::edge_ends and edge_push, branch review41-edge-helpers ported). HOOMD-blue is built on
# the host's cores while the whole CUDA suite runs; then HOOMD-blue's ABP + WCA row, flipflow's at
# 2^10, 2^14 and 2^20 right after, 2^20 after 3 000 steps, Carter side by side and the sweep row
# (session 33's call 3, with the 2^10 row added).
#   bash bench/experiments/session42/s42c4.sh gpu-carry/b42d.tar.xz   carry: gpu-carry (the bundle,
#   hoomd-kit.tgz = ../shared/peers-gpu/hoomd as hoomd-kit/, peers-bundle.tar.gz = ../shared/peers-gpu/bundle)
# (The rows' steps are call_lib.sh's `issue20_rows` now, which took over these lines.)
source tools/gpu/call_lib.sh "${2:-s42c4}" "$1"
declare -A D=([main]=$B)
issue20_rows 1024,16384,1048576
echo done t=$SECONDS >> $I; pack
