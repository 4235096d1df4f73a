#!/bin/bash
# Session 41, call 12 (nvidia-h200): test_overlap_correct_cpu_cuda with the dense block in its
# cases (float and double at 1 500, 2 100 for the cluster's small blocks, 3 000 for the shared
# tail's max_iterations stop) and test_overlap_correct_errors, on main's merged code.
#   bash bench/experiments/session41/s41c12.sh gpu-carry/BUNDLE.tar.gz   carry: gpu-carry
source tools/gpu/call_lib.sh "${2:-s41c12}" "$1"
TEST_TIMEOUT=240 tests "$B" "$O/tests.txt" test_overlap_correct_cpu_cuda test_overlap_correct_errors
step tests 0
echo done t=$SECONDS >> $I; pack
