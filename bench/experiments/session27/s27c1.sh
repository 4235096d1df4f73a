#!/bin/bash
# Session 27, call 1: session 26's prepared first call (next-call1.sh: the whole CUDA suite on
# HEAD f65b106 alone, the 64-run sweep twice, ncu of the correction at 2^10 and 2^14 with L1/L2
# hit rates), then the block-sum helper patch (session26/overlap-block-sum-helper.patch) against
# the correction's CPU == CUDA and determinism tests.
#   bash bench/experiments/session27/s27c1.sh BUNDLE.tar.gz VARIANT.tgz
source tools/gpu/call_lib.sh c1 "$1"
tar -xzf "$2" -C /tmp
suite $B
step suite 0
sw() { rm -rf /tmp/sw; timeout 60 $B/bin/pipeline sweep $B/pipelines/bench-abp.yaml --device cuda --set system.N=16384 \
  --set run.steps=5000 --replicas 64 --out /tmp/sw --concurrent 64 --in-process 2>&1 | tail -2 | sed "s/^/sweep $1: /" >> $O/sweep.txt
  step sweep$1 $?; }
sw 1; sw 2
V=$(shadow bsum /tmp/v27bsum)
tests $V $O/bsum.txt test_overlap_correct_cpu_cuda test_overlap_correct test_overlap_correct_walls \
  test_overlap_correct_determinism test_cpu_cuda_bits test_device_decisions
step bsum-tests 0
ncu_correction 1024 16384
echo done t=$SECONDS >> $I; pack
