#!/bin/bash
# Session 41, call 1 (nvidia-h200): overlap_correct's dense one-block path (dense_block.cuh: a
# small run alone's whole correction in one block's shared memory, every iteration a dense edge
# pass) against main 1a62138's overlap_correct plugin (the cluster team and its shared tail).
# The correction's CUDA tests (CPU == CUDA bits at 1 000-5 000 particles, where the dense path
# runs) and the error cases, then bench-abp at 2^10-2^13, three interleaved rounds.
#   bash bench/experiments/session41/s41c1.sh gpu-carry/BUNDLE.tar.gz gpu-carry/OLDPLUGIN.tar.gz   carry: gpu-carry
source tools/gpu/call_lib.sh "${3:-s41c1}" "$1"
mkdir -p /tmp/oldp && tar -xzf "$2" -C /tmp/oldp
OLD=$(shadow old /tmp/oldp)
declare -A D=([main]=$B [old]=$OLD)
TEST_TIMEOUT=240 correction_tests main
tests "$B" "$O/errors.txt" test_overlap_correct_errors
step errors 0
for r in 1 2 3; do
  for v in main old; do bench_abp $v r$r --sizes ${SIZES:-1024,2048,4096,8192} --steps 200 --warmup 20; done
done
echo done t=$SECONDS >> $I; pack
