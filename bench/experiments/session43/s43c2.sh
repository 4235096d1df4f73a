#!/bin/bash
# Session 43, call 2: what one barrier costs in the dense cluster. Shadow plugins of overlap_correct
# built from main 94fa9b3 with one line added after the reach test's block barrier in the cluster
# path: x1 an extra cluster barrier, x2 an extra block barrier (same iterations, same bits);
# interleaved with main's bundle, three rounds (patch: session43/dense-extra-barrier.patch).
#   bash bench/experiments/session43/s43c2.sh gpu-carry/b43a.tar.xz    carry: gpu-carry
source tools/gpu/call_lib.sh "${2:-s43c2}" "$1"
mkdir -p /tmp/p1 /tmp/p2 && tar -xJf gpu-carry/px1.tar.xz -C /tmp/p1 && tar -xJf gpu-carry/px2.tar.xz -C /tmp/p2
declare -A D=([main]=$B [x1]=$(shadow x1 /tmp/p1) [x2]=$(shadow x2 /tmp/p2))
for r in 1 2 3; do for v in main x1 x2; do bench_abp $v r$r --sizes 2048,4096,8192,16384 --steps 200 --warmup 20; done; done
echo done t=$SECONDS >> $I; pack
