#!/bin/bash
# Session 39, call 4 (nvidia-h200): after type_names.h (trap.harmonic's and observe.mean's types
# through one helper) and the tests' refactors: the executables whose code changed since call 3.
#   bash bench/experiments/session39/s39c4.sh gpu-carry/BUNDLE.tar.gz [NAME]   carry: the bundle
source tools/gpu/call_lib.sh "${2:-s39c4}" "$1"
TEST_TIMEOUT=300 tests "$B" "$O/changed.txt" test_trap_harmonic test_observe_mean test_cpu_cuda_bits test_overlap_correct_errors
step changed-tests 0
echo done t=$SECONDS >> $I; pack
