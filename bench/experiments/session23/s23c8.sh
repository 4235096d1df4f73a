#!/bin/bash
# Session 23, call 8 (one H200): the final commit's CUDA tests of what changed after call 4's
# whole suite (the scheduler's gate reset per attempt, the slot helper, the closed-gate case).
source tools/gpu/call_lib.sh c8 "$1"
T() { local tag=$1; shift; tests $B $O/tests-$tag.txt "$@" & }
T bits test_cpu_cuda_bits test_device_decisions test_deferred_reads
T delaunay test_delaunay_detect_inversion test_delaunay_flip test_delaunay_lawson test_overlap_correct_cpu_cuda
T core test_scheduler test_rollback test_rollback_restores test_graph_capture test_checkpoint test_sweep
wait
{ echo "tests: $(cat $O/tests-*.txt | grep -c "^PASS") PASS, $(cat $O/tests-*.txt | grep -c "^FAIL") FAIL"; grep -h "^FAIL\|^rc=" $O/tests-*.txt; } >> $I
echo done t=$SECONDS >> $I; pack
