#!/bin/bash
# Session 41, call 13 (nvidia-h200): the session's last code (the review's shared-memory limit
# helper, host code; the dense block's loads through load_xy, the same PTX): the correction's six
# CUDA test executables and its error cases, then bench-abp's 2^10 row once.
#   bash bench/experiments/session41/s41c13.sh gpu-carry/BUNDLE.tar.gz   carry: gpu-carry
source tools/gpu/call_lib.sh "${2:-s41c13}" "$1"
declare -A D=([main]=$B)
bench_abp main rows --sizes 1024,2100,4096 --steps 200 --warmup 20
TEST_TIMEOUT=240 correction_tests main
tests "$B" "$O/errors.txt" test_overlap_correct_errors
step errors 0
echo done t=$SECONDS >> $I; pack
