#!/bin/bash
# Session 41, call 2 (nvidia-h200): where the dense one-block kernel's time goes (call 1: slower
# than the cluster team at 2^10-2^12): ncu of dense_kernel at 1 024 and 4 096 particles (one
# launch 120 steps in: stall reasons, instruction mix, per-instruction samples) and its SASS
# (are the shared 64-bit atomics native or CAS loops?). The ncu step is call_lib.sh's
# ncu_correction now (it ran as the same commands written out, without the memory section).
#   bash bench/experiments/session41/s41c2.sh gpu-carry/BUNDLE.tar.gz   carry: gpu-carry
source tools/gpu/call_lib.sh "${2:-s41c2}" "$1"
objdump=$(command -v cuobjdump || ls /usr/local/cuda*/bin/cuobjdump 2>/dev/null | head -n 1)
echo "cuobjdump: $objdump" >> $I
"$objdump" -sass "$B/plugins/libflipflow_stage_overlap_correct.so" 2>/dev/null |
  awk '/Function : .*dense_kernelId/ {p=1} p && /Function : / && !/dense_kernelId/ {p=0} p' > "$O/dense-sass.txt"
grep -c ATOMS "$O/dense-sass.txt" >> $I; grep -o "ATOMS[.A-Z0-9]*" "$O/dense-sass.txt" | sort | uniq -c >> $I
step sass 0
[[ -n ${NCU_SAMPLING:-} ]] && NCU_EXTRA="$NCU_SAMPLING"
NCU_KERNEL=dense_kernel ncu_correction ${SIZES:-1024 4096}
echo done t=$SECONDS >> $I; pack
