#!/bin/bash
# Session 33, call 1: the whole CUDA suite on main 18ef429 (84f91e2's grid_round and the
# correct_parts.cuh move had not run on the GPU), then session 32's next-call2.sh: every element
# loop strided over at most 8 blocks an SM (v33s: every plugin built with
# session32/next-strided-element-loops.patch) against main.
#   bash bench/experiments/session33/s33c1.sh gpu-carry/b33a.tar.gz   carry: b33a, v33s
source tools/gpu/call_lib.sh c1 "$1"
suite "$B" 150
step suite 0
tar -xzf gpu-carry/v33s.tgz -C /tmp
declare -A D=([main]=$B [s]=$(shadow s /tmp/v33s))
TEST_TIMEOUT=200 correction_tests s
for r in 1 2 3; do
  for v in main s; do bench_abp $v r$r --sizes 1024,16384,65536,262144 --steps 200 --warmup 20; done
done
for v in main s main s; do bench_abp $v m20 --sizes 1048576 --steps 200 --warmup 20; done
echo done t=$SECONDS >> $I; pack
