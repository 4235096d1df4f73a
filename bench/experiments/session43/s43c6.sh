#!/bin/bash
# Session 43, call 6: the dense block (one block, n ≤ 1 024) testing only candidate edges between
# rebuilds (branch cand43, session43/dense-candidates.patch): c05 / c10 / c20 = kCandMargin 0.05 /
# 0.1 / 0.2. c10's correction tests and error cases, then bench-abp main / c05 / c10 / c20 at 256,
# 512 and 1 024 particles, three interleaved rounds.
#   bash bench/experiments/session43/s43c6.sh gpu-carry/b43a.tar.xz    carry: gpu-carry
# (Its plugin unpacking, rounds and error cases are call_lib.sh's `variant`, `rounds` and
# `errors_test` now, which took over those lines.)
source tools/gpu/call_lib.sh "${2:-s43c6}" "$1"
declare -A D=([main]=$B)
for v in c05 c10 c20; do D[$v]=$(variant $v gpu-carry/$v.tar.xz); done
TEST_TIMEOUT=240 correction_tests c10
errors_test c10
rounds "main c05 c10 c20" --sizes 256,512,1024 --steps 200 --warmup 20
echo done t=$SECONDS >> $I; pack
