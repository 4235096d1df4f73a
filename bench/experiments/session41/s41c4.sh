#!/bin/bash
# Session 41, call 4 (nvidia-h200): the dense path's counters summed by warp slots instead of
# 64-bit shared atomic adds (compare-and-swap spin loops on sm_90), and the reach tests of a
# thread's edges before their listing; bench-abp at 2^10-2^12 against main 1a62138's plugin
# (three interleaved rounds), then the correction's CUDA tests and the error cases.
#   bash bench/experiments/session41/s41c4.sh gpu-carry/BUNDLE.tar.gz gpu-carry/OLDPLUGIN.tar.gz   carry: gpu-carry
source tools/gpu/call_lib.sh "${3:-s41c4}" "$1"
mkdir -p /tmp/oldp && tar -xzf "$2" -C /tmp/oldp
OLD=$(shadow old /tmp/oldp)
declare -A D=([main]=$B [old]=$OLD)
for r in 1 2 3; do
  for v in main old; do bench_abp $v r$r --sizes ${SIZES:-1024,2048,4096} --steps 200 --warmup 20; done
done
[[ ${SKIP_TESTS:-0} == 1 ]] || { TEST_TIMEOUT=240 correction_tests main; tests "$B" "$O/errors.txt" test_overlap_correct_errors; step errors 0; }
echo done t=$SECONDS >> $I; pack
