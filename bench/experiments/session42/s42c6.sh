#!/bin/bash
# Session 42, call 6: branch dense-writeback42 (the dense kernels write positions to global memory
# once, when the launch ends, not in every iteration's moves) against main 75de0de's plugin,
# interleaved; then the correction's CUDA tests and its error cases.
#   bash bench/experiments/session42/s42c6.sh gpu-carry/b42e.tar.xz gpu-carry/main.tar.xz   carry: gpu-carry
# (Its plugin unpacking, rounds and error cases are call_lib.sh's `variant`, `rounds` and
# `errors_test` now, which took over those lines.)
source tools/gpu/call_lib.sh "${3:-s42c6}" "$1"
declare -A D=([branch]=$B [main]=$(variant main "$2"))
rounds "branch main" --sizes 1024,2048,4096,8192,16384 --steps 200 --warmup 20
TEST_TIMEOUT=240 correction_tests branch
errors_test branch
echo done t=$SECONDS >> $I; pack
