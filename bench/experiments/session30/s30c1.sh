#!/bin/bash
# Session 30, call 1: branch blk30 (the one-block kernel with the state in shared memory for a run
# alone of up to ~2 900 particles): the correction's six CUDA test executables on its bundle, then
# bench-abp 200 steps after 20 at 2^10 / 2^11 / 2^12 against main's plugin (8649246) shadowed into
# the same bundle, three interleaved rounds (2^12 runs the cluster in both: the control).
#   bash bench/experiments/session30/s30c1.sh gpu-carry/b30.tar.gz     carry: the bundle, v30main.tgz
source tools/gpu/call_lib.sh c1 "$1"
tar -xzf gpu-carry/v30main.tgz -C /tmp
declare -A D=([blk]=$B [main]=$(shadow main /tmp/v30main))
TEST_TIMEOUT=240 correction_tests blk
for r in 1 2 3; do
  bench_abp main small --sizes 1024,2048,4096 --steps 200 --warmup 20
  bench_abp blk small --sizes 1024,2048,4096 --steps 200 --warmup 20
done
echo done t=$SECONDS >> $I; pack
