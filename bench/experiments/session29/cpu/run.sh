#!/bin/bash
# CPU A/B, hard disks N = 2^16, Δt 1e-3, 2 threads: aae16dd's overlap_correct plugin (old) against
# main's (new, pm29 + fin29), interleaved rounds.
cd /tmp/cpuab
for r in 1 2 3 4; do
  for v in old new new old; do
    ./$v/bin/pipeline bench ./$v/pipelines/hard-disks.yaml --device cpu --threads 2 --sizes 65536 --steps 100 \
      --warmup 200 --set run.dt=1e-3 2>&1 | grep -E "^[0-9]|iter" | sed "s/^/$v r$r: /"
    echo "$v load $(cut -d' ' -f1 /proc/loadavg)"
  done
done
