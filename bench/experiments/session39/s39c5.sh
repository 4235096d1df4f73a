#!/bin/bash
# Session 39, call 5 (nvidia-h200): after the review's tidying (core/backend/not_computed.h; the
# metric stamps' collection and checkpoint; observe.msd's reference): the executables over that code.
#   bash bench/experiments/session39/s39c5.sh gpu-carry/BUNDLE.tar.gz [NAME]   carry: the bundle
source tools/gpu/call_lib.sh "${2:-s39c5}" "$1"
TEST_TIMEOUT=400 tests "$B" "$O/changed.txt" test_observe_h5md test_observe_mean test_observe_msd test_checkpoint test_cpu_cuda_bits test_trap_harmonic
step changed-tests 0
echo done t=$SECONDS >> $I; pack
