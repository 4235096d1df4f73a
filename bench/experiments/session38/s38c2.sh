#!/bin/bash
# Session 38, call 2 (nvidia-h200): did the metric stamps (RunStats::metric_stamps, collected in
# Simulation::collect_metrics every step) cost the small step? Call 1 measured bench-abp 2^10 at
# 14 124 steps/s against 14 851-15 123 in sessions 35-37. A/B in one lease: the session's bundle
# (main) against a933f35's pipeline, core library and plugins (old) in a copy of it, three
# interleaved rounds at 2^10 and 2^14.
#   bash bench/experiments/session38/s38c2.sh gpu-carry/BUNDLE.tar.gz gpu-carry/OLD.tar.gz [NAME]
source tools/gpu/call_lib.sh "${3:-s38c2}" "$1"
OLD=/tmp/old-bundle
rm -rf "$OLD" && cp -a "$B" "$OLD" && tar -xzf "$2" -C "$OLD"
echo "old: $(tar -tzf "$2" | wc -l) files of a933f35 over a copy of the bundle" >> "$I"
declare -A D=([main]=$B [old]=$OLD)
for r in 1 2 3; do
  for v in main old; do bench_abp $v r$r --sizes 1024,16384; done
  for v in old main; do bench_abp $v r${r}b --sizes 1024,16384; done
done
echo done t=$SECONDS >> $I; pack
