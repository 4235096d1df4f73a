#!/bin/bash
# Session 42, call 7: branch dense-split42 (the dense cluster waits for the barrier after the moves
# only after the next reach test of the edges a block holds both ends of) against main 75de0de's plugin,
# interleaved; then the correction's CUDA tests and its error cases.
#   bash bench/experiments/session42/s42c7.sh gpu-carry/b42f.tar.xz gpu-carry/main.tar.xz   carry: gpu-carry
source tools/gpu/call_lib.sh "${3:-s42c7}" "$1"
mkdir -p /tmp/pM && tar -xJf "$2" -C /tmp/pM
declare -A D=([branch]=$B [main]=$(shadow main /tmp/pM))
for r in 1 2 3; do for v in branch main; do bench_abp $v r$r --sizes 1024,2048,4096,8192,16384 --steps 200 --warmup 20; done; done
TEST_TIMEOUT=240 correction_tests branch
tests "$B" "$O/errors.txt" test_overlap_correct_errors
step errors 0
echo done t=$SECONDS >> $I; pack
