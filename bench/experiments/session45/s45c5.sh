#!/bin/bash
# Session 45, call 5: where the host's own ~37 us a step (call 4, 2^10) goes: host_waits.c now
# also records event records, stream waits, async copies and memsets, and each launch's kernel
# (dladdr of its host stub); host_waits.py prints the typical step's calls in order. Then, where
# the machine has perf, a profile of the host at 2^10.
#   bash bench/experiments/session45/s45c5.sh gpu-carry/b45n.tar.xz    carry: gpu-carry (b45n)
source tools/gpu/call_lib.sh s45c5 "$1"
# (these calls ran the same lines written out, from bench/experiments/session45; call_lib.sh's
# host_waits came after them)
host_waits 1024 16384
{ command -v perf; command -v gdb; command -v valgrind; } > $O/tools.txt 2>&1
if command -v perf > /dev/null; then
  timeout 60 perf record -F 10000 -g -o /tmp/perf.data "$B/bin/pipeline" bench "$B/pipelines/bench-abp.yaml" --device cuda \
    --sizes 1024 --steps 3000 --warmup 20 > $O/perf-run.txt 2>&1
  perf report -i /tmp/perf.data --stdio --no-children --sort dso,symbol 2>/dev/null | head -150 > $O/perf-report.txt
  step perf 0
fi
echo done t=$SECONDS >> $I; pack
