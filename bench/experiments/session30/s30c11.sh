#!/bin/bash
# Session 30, call 11: main at 713c209 (grp30 merged: the shared tail by lane groups at every
# count): the correction's six CUDA test executables, then bench-abp 200 steps after 20 at 2^10 -
# 2^14 against wt (c8241d9's plugin: the shared tail as merged before, = 2e896b5), three rounds.
#   bash bench/experiments/session30/s30c11.sh gpu-carry/b30g.tar.gz    carry: the bundle, v30wt.tgz
source tools/gpu/call_lib.sh c11 "$1"
tar -xzf gpu-carry/v30wt.tgz -C /tmp
declare -A D=([head]=$B [wt]=$(shadow wt /tmp/v30wt))
TEST_TIMEOUT=240 correction_tests head
for r in 1 2 3; do
  for v in wt head; do bench_abp $v small --sizes 1024,2048,4096,8192,16384 --steps 200 --warmup 20; done
done
echo done t=$SECONDS >> $I; pack
