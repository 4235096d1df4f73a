#!/bin/bash
# Session 27, call 1: session 26's prepared first call (next-call1.sh: the whole CUDA suite on
# HEAD f65b106 alone, the 64-run sweep twice, ncu of the correction at 2^10 and 2^14 with L1/L2
# hit rates), then the block-sum helper patch (session26/overlap-block-sum-helper.patch) against
# the correction's CPU == CUDA and determinism tests.
# (It ran with its sweep written out; that is call_lib.sh's sweep_abp now, which reports the
# sweep's exit code rather than sed's.)
#   bash bench/experiments/session27/s27c1.sh BUNDLE.tar.gz VARIANT.tgz
source tools/gpu/call_lib.sh c1 "$1"
tar -xzf "$2" -C /tmp
suite $B
step suite 0
sweep_abp 1; sweep_abp 2
V=$(shadow bsum /tmp/v27bsum)
tests $V $O/bsum.txt test_overlap_correct_cpu_cuda test_overlap_correct test_overlap_correct_walls \
  test_overlap_correct_determinism test_cpu_cuda_bits test_device_decisions
step bsum-tests 0
ncu_correction 1024 16384
echo done t=$SECONDS >> $I; pack
