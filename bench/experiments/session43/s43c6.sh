#!/bin/bash
# Session 43, call 6: the dense block (one block, n ≤ 1 024) testing only candidate edges between
# rebuilds (branch cand43, session43/dense-candidates.patch): c05 / c10 / c20 = kCandMargin 0.05 /
# 0.1 / 0.2. c10's correction tests and error cases, then bench-abp main / c05 / c10 / c20 at 256,
# 512 and 1 024 particles, three interleaved rounds.
#   bash bench/experiments/session43/s43c6.sh gpu-carry/b43a.tar.xz    carry: gpu-carry
source tools/gpu/call_lib.sh "${2:-s43c6}" "$1"
for v in c05 c10 c20; do mkdir -p /tmp/$v && tar -xJf gpu-carry/$v.tar.xz -C /tmp/$v; done
declare -A D=([main]=$B [c05]=$(shadow c05 /tmp/c05) [c10]=$(shadow c10 /tmp/c10) [c20]=$(shadow c20 /tmp/c20))
TEST_TIMEOUT=240 correction_tests c10
tests "${D[c10]}" "$O/errors.txt" test_overlap_correct_errors
step errors 0
for r in 1 2 3; do for v in main c05 c10 c20; do bench_abp $v r$r --sizes 256,512,1024 --steps 200 --warmup 20; done; done
echo done t=$SECONDS >> $I; pack
