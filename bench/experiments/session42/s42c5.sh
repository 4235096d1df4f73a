#!/bin/bash
# Session 42, call 5: ncu of the dense cluster (dense_kernel, main 75de0de's bundle b42d from
# 21199d4) at 16 384 particles (16 blocks of 1 024) and 4 096 (16 of 256), and of the one block at
# 1 024, with dense warp sampling: where an iteration's time goes (cluster barriers, distributed
# shared memory, instructions).
#   bash bench/experiments/session42/s42c5.sh gpu-carry/b42d.tar.xz   carry: gpu-carry
source tools/gpu/call_lib.sh "${2:-s42c5}" "$1"
NCU_KERNEL=dense_kernel NCU_EXTRA="--warp-sampling-interval 0" ncu_correction 16384 4096 1024
echo done t=$SECONDS >> $I; pack
