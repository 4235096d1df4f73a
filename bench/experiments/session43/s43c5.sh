#!/bin/bash
# Session 43, call 5: the one-barrier dense cluster with its foreign edges' reach tests in a loop of
# their own (pv, branch onebar43's third commit) against main, pw (call 4) and ps (the set-up
# alone); pv's correction tests first.
#   bash bench/experiments/session43/s43c5.sh gpu-carry/b43a.tar.xz    carry: gpu-carry
# (Its plugin unpacking, rounds and error cases are call_lib.sh's `variant`, `rounds` and
# `errors_test` now, which took over those lines.)
source tools/gpu/call_lib.sh "${2:-s43c5}" "$1"
declare -A D=([main]=$B)
for v in pv pw ps; do D[$v]=$(variant $v gpu-carry/$v.tar.xz); done
TEST_TIMEOUT=240 correction_tests pv
rounds "main pv pw ps" --sizes 2048,4096,16384 --steps 200 --warmup 20
echo done t=$SECONDS >> $I; pack
