#!/bin/bash
# Session 47, call 9: ncu of main's one-block dense kernel at 1 024 particles (three launches 120
# steps in, the densest warp sampling): its stall reasons by SASS instruction, to place the
# iteration floor calls 3 and 6 measured (~4 300 cycles when almost nothing is left) against
# barrier_cost's parts (a barrier ~350 cycles at 1 024 threads, a move's chain ~400).
#   bash bench/experiments/session47/s47g.sh gpu-carry/b47.tar.xz    carry: gpu-carry (b47)
source tools/gpu/call_lib.sh s47g "$1"
NCU_KERNEL=dense_kernel NCU_LAUNCHES=3 NCU_EXTRA="--warp-sampling-interval 0" ncu_correction 1024
echo done t=$SECONDS >> $I; pack
