#!/bin/bash
# Session 50, call 5: ncu of the one-block correction at 1 024 particles (bench-abp, three launches
# from the 120th), per-instruction stall sampling: main's edge pass (dense_kernel) and branch
# gather50's kernel by particles (gather_block_kernel), to place the late iterations' ~4 400 cycles.
# (As it ran, the profile was a copy of ncu_correction's lines with five of its eight sections and
# 130 warm-up steps; that step is now call_lib.sh's ncu_profile.)
#   bash bench/experiments/session50/s50c5.sh gpu-carry/b49f.tar.xz   carry: gpu-carry/b49f.tar.xz, gpu-carry/vgather.tar.xz
source tools/gpu/call_lib.sh s50c5 "$1"
declare -A D=([main]=$B)
D[gather]=$(variant gather gpu-carry/vgather.tar.xz)
NCU_LAUNCHES=3 NCU_KERNEL=dense_kernel ncu_profile main "${D[main]}" 1024
NCU_LAUNCHES=3 NCU_KERNEL=gather_block_kernel ncu_profile gather "${D[gather]}" 1024
echo done t=$SECONDS >> $I; pack
