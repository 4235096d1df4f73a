#!/bin/bash
# Session 43, call 5: the one-barrier dense cluster with its foreign edges' reach tests in a loop of
# their own (pv, branch onebar43's third commit) against main, pw (call 4) and ps (the set-up
# alone); pv's correction tests first.
#   bash bench/experiments/session43/s43c5.sh gpu-carry/b43a.tar.xz    carry: gpu-carry
source tools/gpu/call_lib.sh "${2:-s43c5}" "$1"
for v in pv pw ps; do mkdir -p /tmp/$v && tar -xJf gpu-carry/$v.tar.xz -C /tmp/$v; done
declare -A D=([main]=$B [pv]=$(shadow pv /tmp/pv) [pw]=$(shadow pw /tmp/pw) [ps]=$(shadow ps /tmp/ps))
TEST_TIMEOUT=240 correction_tests pv
for r in 1 2 3; do for v in main pv pw ps; do bench_abp $v r$r --sizes 2048,4096,16384 --steps 200 --warmup 20; done; done
echo done t=$SECONDS >> $I; pack
