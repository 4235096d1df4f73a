#!/bin/bash
# Session 23, call 1 (one H200), bundle of main with device decisions (StepContext::gate):
# the CUDA tests of the change and of session 22's untested host edits, test_tran_aggregation
# (not run on CUDA in session 22), bench-abp with FLIPFLOW_DEVICE_DECISIONS=1/0 interleaved, and
# CUPTI traces at 2^10 and 2^14.
source tools/gpu/call_lib.sh c1 "$1"
T() { local tag=$1; shift; tests $B $O/tests-$tag.txt "$@" & }
T bits test_cpu_cuda_bits
T delaunay test_delaunay_detect_inversion test_delaunay_flip test_delaunay_lawson test_delaunay_tries test_overlap_correct_cpu_cuda
T core test_device_decisions test_deferred_reads test_scheduler test_rollback test_rollback_restores test_graph_capture test_checkpoint test_overlap_correct test_overlap_correct_walls
TEST_TIMEOUT=200 T tran test_tran_aggregation
wait
{ echo "tests: $(cat $O/tests-*.txt | grep -c "^PASS") PASS, $(cat $O/tests-*.txt | grep -c "^FAIL") FAIL"; grep -h "^FAIL\|^rc=" $O/tests-*.txt; } >> $I
step tests 0
P=$B/pipelines
b() { local v=$1 tag=$2; shift 2
  FLIPFLOW_DEVICE_DECISIONS=$v timeout 60 $B/bin/pipeline bench $P/bench-abp.yaml --device cuda "$@" 2>&1 |
    grep -E "^[0-9]|decided_on_device|overlap_correct/iter" | sed "s/^/dd=$v $tag: /" >> $O/ab.txt; step dd$v-$tag $?; }
for v in 1 0 0 1 1 0; do b $v small --sizes 1024,4096,16384 --steps 300 --warmup 20; done
for n in 1024 16384; do CUDA_INJECTION64_PATH=$B/lib/libflipflow_gpu_trace.so FLIPFLOW_GPU_TRACE=$O/trace-$n.csv timeout 30 $B/bin/pipeline bench $P/bench-abp.yaml --device cuda --sizes $n --steps 30 --warmup 20 > $O/trace-$n.txt 2>&1; step trace-$n $?; done
for v in 1 0; do ((SECONDS < 420)) && b $v big --sizes 1048576 --steps 200 --warmup 20; done
echo done t=$SECONDS >> $I; pack
