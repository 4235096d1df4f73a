#!/bin/bash
# Session 39, call 2 (nvidia-h200): trap.harmonic's velocity and types on CUDA: test_trap_harmonic
# (exact moving centre and type selection, the drag lag, the hard-disk balance, CPU == CUDA bits)
# and test_cpu_cuda_bits (its new moving-trap pipeline case among the others).
#   bash bench/experiments/session39/s39c2.sh gpu-carry/BUNDLE.tar.gz [NAME]   carry: the bundle
source tools/gpu/call_lib.sh "${2:-s39c2}" "$1"
TEST_TIMEOUT=300 tests "$B" "$O/trap.txt" test_trap_harmonic test_cpu_cuda_bits
step trap-tests 0
echo done t=$SECONDS >> $I; pack
