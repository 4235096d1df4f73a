#!/bin/bash
# Session 42, call 1: overlap_correct's dense cluster (branch dense-cluster42: dense_block.cuh's
# kernel on a cluster of up to 16 blocks of 1 024 particles, sm_90 distributed shared memory) for
# runs alone of 2 049-16 384 particles. A short run first (a hang shows as a timeout), then
# bench-abp interleaved against main 24aca08's plugin at sizes on both sides of the old thresholds,
# then the correction's six CUDA test executables (the dense cluster now takes test_overlap_correct_cpu_cuda's
# 2100-16384 cases).
#   bash bench/experiments/session42/s42c1.sh gpu-carry/b42a.tar.gz gpu-carry/mainplug.tar.gz   carry: gpu-carry
source tools/gpu/call_lib.sh "${3:-s42c1}" "$1"
mkdir -p /tmp/mp && tar -xzf "$2" -C /tmp/mp
declare -A D=([branch]=$B [main]=$(shadow main /tmp/mp))
BENCH_TIMEOUT=40 bench_abp branch smoke --sizes 4096 --steps 20 --warmup 5
for r in 1 2 3; do for v in branch main; do bench_abp $v r$r --sizes 1024,2048,3072,4096,8192,12288,16384 --steps 200 --warmup 20; done; done
TEST_TIMEOUT=240 correction_tests branch
echo done t=$SECONDS >> $I; pack
