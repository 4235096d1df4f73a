#!/bin/bash
# Prepared in session 25, not yet run: ncu of overlap_correct's cluster kernel at 2^10 (one launch
# after 120 steps, past the lattice's easy start), with per-instruction stall sampling, to tell
# whether a tail gather's ~6 000 cycles (session 25's phase profile) are memory latency or fp64
# arithmetic: the SASS lines of gather_ids' loads against those of pair_term's square root and
# divisions. A shared-memory tail (branch smallshm, session 14) pays only for the first.
#   bash bench/experiments/session25/next-ncu-tail.sh BUNDLE.tar.gz      carry: the bundle
source tools/gpu/call_lib.sh ncu-tail "$1"
NCU=$(command -v ncu || ls /usr/local/cuda*/bin/ncu /opt/nvidia/nsight-compute/*/ncu 2>/dev/null | head -n 1)
echo "ncu: ${NCU:-none}" >> $I
for n in 1024 16384; do
  timeout 240 "$NCU" --target-processes all --clock-control none -k regex:correct_kernel \
    --launch-skip 120 --launch-count 1 \
    --section LaunchStats --section Occupancy --section SchedulerStats --section WarpStateStats \
    --section InstructionStats --section SpeedOfLight --section SourceCounters \
    -f -o "$O/oc-$n" "$B/bin/pipeline" bench "$B/pipelines/bench-abp.yaml" --device cuda --sizes $n \
    --steps 1 --warmup 125 > "$O/ncu-run-$n.txt" 2>&1
  step ncu-$n $?
  [[ -f $O/oc-$n.ncu-rep ]] || continue
  "$NCU" -i "$O/oc-$n.ncu-rep" --page details > "$O/ncu-details-$n.txt" 2>&1
  "$NCU" -i "$O/oc-$n.ncu-rep" --page source --csv --print-source sass 2>&1 | xz > "$O/ncu-sass-$n.csv.xz"
  rm -f "$O/oc-$n.ncu-rep"; step ncu-export-$n 0
done
echo done t=$SECONDS >> $I; pack
