#!/bin/bash
# Session 41, call 3 (nvidia-h200): the dense path, second form (listed edges, pushes linked into
# each end's list by 32-bit exchanges instead of 64-bit shared atomics), against main 1a62138's plugin,
# the cluster team and its shared tail. The correction's CUDA tests and the error cases, then
# bench-abp at 2^10-2^12 (2^12: above the path's 2 048, the same code in both), three rounds.
#   bash bench/experiments/session41/s41c3.sh gpu-carry/BUNDLE.tar.gz gpu-carry/OLDPLUGIN.tar.gz   carry: gpu-carry
source tools/gpu/call_lib.sh "${3:-s41c3}" "$1"
mkdir -p /tmp/oldp && tar -xzf "$2" -C /tmp/oldp
OLD=$(shadow old /tmp/oldp)
declare -A D=([main]=$B [old]=$OLD)
TEST_TIMEOUT=240 correction_tests main
tests "$B" "$O/errors.txt" test_overlap_correct_errors
step errors 0
for r in 1 2 3; do
  for v in main old; do bench_abp $v r$r --sizes 1024,2048,4096 --steps 200 --warmup 20; done
done
echo done t=$SECONDS >> $I; pack
