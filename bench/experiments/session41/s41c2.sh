#!/bin/bash
# Session 41, call 2 (nvidia-h200): where the dense one-block kernel's time goes (call 1: slower
# than the cluster team at 2^10-2^12): ncu of dense_kernel at 1 024 and 4 096 particles (one
# launch 120 steps in: stall reasons, instruction mix, per-instruction samples) and its SASS
# (are the shared 64-bit atomics native or CAS loops?).
#   bash bench/experiments/session41/s41c2.sh gpu-carry/BUNDLE.tar.gz   carry: gpu-carry
source tools/gpu/call_lib.sh "${2:-s41c2}" "$1"
ncu=$(command -v ncu || ls /usr/local/cuda*/bin/ncu /opt/nvidia/nsight-compute/*/ncu 2>/dev/null | head -n 1)
objdump=$(command -v cuobjdump || ls /usr/local/cuda*/bin/cuobjdump 2>/dev/null | head -n 1)
echo "ncu: $ncu cuobjdump: $objdump" >> $I
"$objdump" -sass "$B/plugins/libflipflow_stage_overlap_correct.so" 2>/dev/null |
  awk '/Function : .*dense_kernelId/ {p=1} p && /Function : / && !/dense_kernelId/ {p=0} p' > "$O/dense-sass.txt"
grep -c ATOMS "$O/dense-sass.txt" >> $I; grep -o "ATOMS[.A-Z0-9]*" "$O/dense-sass.txt" | sort | uniq -c >> $I
step sass 0
for n in 1024 4096; do
  timeout 200 "$ncu" --target-processes all --clock-control none -k regex:dense_kernel \
    --launch-skip 120 --launch-count 1 \
    --section LaunchStats --section Occupancy --section SchedulerStats --section WarpStateStats \
    --section InstructionStats --section SpeedOfLight --section SourceCounters \
    -f -o "$O/dense-$n" "$B/bin/pipeline" bench "$B/pipelines/bench-abp.yaml" --device cuda --sizes "$n" \
    --steps 1 --warmup 125 > "$O/ncu-run-$n.txt" 2>&1
  step "ncu-$n" $?
  [[ -f $O/dense-$n.ncu-rep ]] || continue
  "$ncu" -i "$O/dense-$n.ncu-rep" --page details > "$O/ncu-details-$n.txt" 2>&1
  "$ncu" -i "$O/dense-$n.ncu-rep" --page source --csv --print-source sass 2>&1 | xz > "$O/ncu-sass-$n.csv.xz"
  rm -f "$O/dense-$n.ncu-rep"
  step "ncu-export-$n" 0
done
echo done t=$SECONDS >> $I; pack
