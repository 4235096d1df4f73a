#!/bin/bash
# Session 41, call 6 (nvidia-h200): ncu of the dense kernel after call 5 (warp-slot sums), with
# the densest stall sampling, three launches 120 steps in, at 1 024 and 2 048 particles: stall
# reasons, instruction mix, per-instruction samples; and its SASS.
#   bash bench/experiments/session41/s41c6.sh gpu-carry/BUNDLE.tar.gz   carry: gpu-carry
source tools/gpu/call_lib.sh "${2:-s41c6}" "$1"
ncu=$(command -v ncu || ls /usr/local/cuda*/bin/ncu /opt/nvidia/nsight-compute/*/ncu 2>/dev/null | head -n 1)
objdump=$(command -v cuobjdump || ls /usr/local/cuda*/bin/cuobjdump 2>/dev/null | head -n 1)
echo "ncu: $ncu cuobjdump: $objdump" >> $I
"$objdump" -sass "$B/plugins/libflipflow_stage_overlap_correct.so" 2>/dev/null |
  awk '/Function : .*dense_kernelId/ {p=1} p && /Function : / && !/dense_kernelId/ {p=0} p' > "$O/dense-sass.txt"
grep -c ATOMS "$O/dense-sass.txt" >> $I; grep -o "ATOMS[.A-Z0-9]*" "$O/dense-sass.txt" | sort | uniq -c >> $I
step sass 0
"$ncu" --help 2>&1 | grep -i -A2 "sampling" > "$O/ncu-help.txt"
samp=$(grep -o -- "--warp-sampling-interval" "$O/ncu-help.txt" | head -1)
echo "sampling option: ${samp:-none}" >> $I
for n in 1024 2048; do
  timeout 200 "$ncu" --target-processes all --clock-control none -k regex:dense_kernel \
    --launch-skip 120 --launch-count 3 ${samp:+$samp 0} \
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
