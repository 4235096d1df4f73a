#!/bin/bash
# Session 41, call 14 (not run: the session's device time was spent), for branch
# review41-edge-helpers: the dense block checks its edge records and makes its pushes through
# kernel.h's Overlaps::edge_ends and edge_push (the CPU edge pass's, now helpers of edge()); its
# PTX changed in the records' loop. Run the correction's six CUDA test executables and the error
# cases, then bench-abp 2^10 against main's plugin; merge the branch if they pass and 2^10 ties.
#   bash bench/experiments/session41/s41c14.sh gpu-carry/BUNDLE.tar.gz gpu-carry/MAINPLUGIN.tar.gz   carry: gpu-carry
source tools/gpu/call_lib.sh "${3:-s41c14}" "$1"
mkdir -p /tmp/mp && tar -xzf "$2" -C /tmp/mp
declare -A D=([branch]=$B [main]=$(shadow main /tmp/mp))
for r in 1 2 3; do for v in branch main; do bench_abp $v r$r --sizes 1024,2048 --steps 200 --warmup 20; done; done
TEST_TIMEOUT=240 correction_tests branch
tests "$B" "$O/errors.txt" test_overlap_correct_errors
step errors 0
echo done t=$SECONDS >> $I; pack
