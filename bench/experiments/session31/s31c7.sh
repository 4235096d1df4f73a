#!/bin/bash
# Session 31, call 7: ncu of delaunay.lawson's tail kernel (main 8925864's plugin, one block) at
# 2^14 and 2^16 (one launch 120 steps in; warp stalls per SASS instruction), to see what its apply
# waits for.
#   bash bench/experiments/session31/s31c7.sh gpu-carry/b31c.tar.gz gpu-carry/v31pub.tgz
source tools/gpu/call_lib.sh c7 "$1"
tar -xzf "$2" -C /tmp
P=$(shadow pub /tmp/v31pub)
ncu=$(command -v ncu || ls /usr/local/cuda*/bin/ncu /opt/nvidia/nsight-compute/*/ncu 2>/dev/null | head -n 1)
echo "ncu: ${ncu:-none}" >> $I
for n in 16384 65536; do
  timeout 200 "$ncu" --target-processes all --clock-control none -k regex:tail_kernel --launch-skip 120 --launch-count 1 \
    --section LaunchStats --section WarpStateStats --section SourceCounters --section MemoryWorkloadAnalysis \
    --section SchedulerStats --section SpeedOfLight \
    -f -o $O/lt-$n $P/bin/pipeline bench $P/pipelines/bench-abp.yaml --device cuda --sizes $n --steps 1 --warmup 125 > $O/ncu-run-$n.txt 2>&1
  step ncu-$n $?
  [[ -f $O/lt-$n.ncu-rep ]] || continue
  "$ncu" -i $O/lt-$n.ncu-rep --page details > $O/ncu-details-$n.txt 2>&1
  "$ncu" -i $O/lt-$n.ncu-rep --page source --csv --print-source sass 2>&1 | xz > $O/ncu-sass-$n.csv.xz
  rm -f $O/lt-$n.ncu-rep
  step ncu-export-$n 0
done
echo done t=$SECONDS >> $I; pack
