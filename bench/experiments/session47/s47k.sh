#!/bin/bash
# Session 47, call 13: ncu of main's Lawson tail kernel (one block) in bench-abp at 1 024
# particles, three launches 120 steps in, the densest warp sampling: where call 12's ~2 000-4 500
# cycles a phase go, by SASS instruction.
#   bash bench/experiments/session47/s47k.sh gpu-carry/b47.tar.xz    carry: gpu-carry (b47)
source tools/gpu/call_lib.sh s47k "$1"
NCU_KERNEL=tail_kernel NCU_LAUNCHES=3 NCU_EXTRA="--warp-sampling-interval 0" ncu_correction 1024
echo done t=$SECONDS >> $I; pack
