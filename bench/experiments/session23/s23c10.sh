#!/bin/bash
# Session 23, call 10 (one H200): the final commit (device decisions and programmatic dependent
# launches on main): the CUDA tests of the stages they touch, and bench-abp at 2^10, 2^12, 2^14,
# deciding on the device and on the host, two interleaved rounds.
source tools/gpu/call_lib.sh c10 "$1"
T() { local tag=$1; shift; tests $B $O/tests-$tag.txt "$@" & }
T bits test_cpu_cuda_bits test_device_decisions
T stages test_delaunay_detect_inversion test_delaunay_flip test_delaunay_lawson test_overlap_correct test_overlap_correct_walls test_graph_capture
T cpucuda test_overlap_correct_cpu_cuda
wait
{ echo "tests: $(cat $O/tests-*.txt | grep -c "^PASS") PASS, $(cat $O/tests-*.txt | grep -c "^FAIL") FAIL"; grep -h "^FAIL" $O/tests-*.txt; } >> $I
step tests 0
P=$B/pipelines
b() { local v=$1; shift
  FLIPFLOW_DEVICE_DECISIONS=$v timeout 60 $B/bin/pipeline bench $P/bench-abp.yaml --device cuda "$@" 2>&1 |
    grep -E "^[0-9]|decided_on_device|overlap_correct/iter" | sed "s/^/dd=$v: /" >> $O/ab.txt; step dd$v $?; }
for v in 1 0 0 1; do b $v --sizes 1024,4096,16384 --steps 300 --warmup 20; done
echo done t=$SECONDS >> $I; pack
