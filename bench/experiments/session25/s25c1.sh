#!/bin/bash
# Session 25, call 1 (one H200, bundle b24b of 636b54a = HEAD's code): why bench-abp's steps in a
# row (11.5k steps/s at 2^10, 86.8 us a step) are slower than session 23's traced typical step
# (59.3 us): the throughput pass at several lengths, and a trace of a 300-step pass with one line
# a step. Then the 7 CUDA test executables call 4 of session 24 did not reach.
#   carry: gpu-carry/b24b.tar.gz
source tools/gpu/call_lib.sh c1 "$1"
b() { local tag=$1; shift
  timeout 120 $B/bin/pipeline bench $B/pipelines/bench-abp.yaml --device cuda "$@" 2>&1 |
    grep -E "^[0-9]|overlap_correct/iter" | sed "s/^/$tag: /" >> $O/ab.txt; step $tag $?; }
for s in 30 300 3000; do b s$s --sizes 1024,16384 --steps $s --warmup 20; done
b s300again --sizes 1024,16384 --steps 300 --warmup 20
for n in 1024 16384; do
  CUDA_INJECTION64_PATH=$B/lib/libflipflow_gpu_trace.so FLIPFLOW_GPU_TRACE=$O/trace-$n.csv timeout 60 \
    $B/bin/pipeline bench $B/pipelines/bench-abp.yaml --device cuda --sizes $n --steps 300 --warmup 20 > $O/trace-$n.txt 2>&1
  step trace-$n $?
  python3 tools/gpu_trace/summarize.py $O/trace-$n.csv --skip 20 --count 300 --per-step > $O/trace-$n-summary.txt 2>&1
  gzip -f $O/trace-$n.csv; step sum-$n $?
done
TEST_TIMEOUT=300 tests $B $O/tests.txt test_overlap_correct_cpu_cuda test_overlap_correct_walls test_pair_lj test_pipeline_fuzz test_render test_rollback_stress test_tran_aggregation
step tests 0
echo done t=$SECONDS >> $I; pack
