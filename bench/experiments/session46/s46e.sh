#!/bin/bash
# Session 46, call 5: what the correction costs in bench-abp's step at small N, without CUPTI
# (whose per-kernel durations overlap under programmatic launches: a kernel's time includes its
# wait for the one before). bench-abp as shipped, without overlap_correct, and abp.integrate
# alone, three interleaved rounds at 256 to 16 384 on main 4f74f74's bundle.
#   bash bench/experiments/session46/s46e.sh gpu-carry/b46a.tar.xz    carry: gpu-carry (b46a)
source tools/gpu/call_lib.sh s46e "$1"
P=$B/pipelines/bench-abp.yaml
grep -v "stage: overlap_correct" $P > /tmp/nocorr.yaml
grep -v "stage: delaunay\.\|stage: overlap_correct" $P > /tmp/integrate.yaml
for r in 1 2 3; do
  for v in full nocorr integrate; do
    f=$P; [ $v = nocorr ] && f=/tmp/nocorr.yaml; [ $v = integrate ] && f=/tmp/integrate.yaml
    timeout 100 $B/bin/pipeline bench $f --device cuda --sizes 256,1024,4096,16384 --steps 400 --warmup 20 \
      --results /tmp/r-$v-$r > /tmp/o.txt 2>&1
    step $v-r$r $?
    grep -E "^[0-9]+ |host's own" /tmp/o.txt | sed "s/^/$v r$r: /" >> $O/split.txt
  done
done
echo done t=$SECONDS >> $I; pack
