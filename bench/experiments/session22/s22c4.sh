#!/bin/bash
# Session 22, call 4 (one H200), bundle of branch defer22 39d3d41: reads left past the step
# (overlap_correct's read waits until the next step's kernels are queued). CUDA tests, then
# bench-abp with FLIPFLOW_DEFERRED_READS=0 ("within") against the default ("late"), interleaved;
# CUPTI timelines of the default at 2^10 and 2^14.
set -u
SECONDS=0
tar -xzf gpu-carry/bundle-s22d.tar.gz
B=$PWD/bundle; O=/tmp/c4; rm -rf $O; mkdir -p $O
I=$O/info.txt
{ nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv; head -1 $B/.flipflow-bundle; } > $I
pack() { (cd /tmp && tar -czf $OUT/c4.tgz.part c4 && mv $OUT/c4.tgz.part $OUT/c4.tgz); }
step() { echo "$1 rc=$2 t=$SECONDS" >> $I; pack; }
(cd $B && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 150 bin/run-tests test_cpu_cuda_bits test_graph_capture test_rollback test_rollback_restores > $O/tests-a.txt 2>&1; echo "rc=$?" >> $O/tests-a.txt) &
(cd $B && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 150 bin/run-tests test_overlap_correct test_overlap_correct_walls test_overlap_correct_determinism test_overlap_correct_cpu_cuda test_overlap_correct_errors test_scheduler test_sweep test_checkpoint test_delaunay_lawson > $O/tests-b.txt 2>&1; echo "rc=$?" >> $O/tests-b.txt) &
wait
{ echo "tests: $(cat $O/tests-*.txt | grep -c "^PASS") PASS, $(cat $O/tests-*.txt | grep -c "^FAIL") FAIL"; grep -h "^FAIL" $O/tests-*.txt; } >> $I
step tests 0
P=$B/pipelines
b() { local v=$1 tag=$2; shift 2; local e=""; [[ $v == within ]] && e=0
  FLIPFLOW_DEFERRED_READS=${e:-1} timeout 70 $B/bin/pipeline bench $P/bench-abp.yaml --device cuda "$@" 2>&1 | grep -E "^[0-9]|overlap_correct/|lawson/" | sed "s/^/$v $tag: /" >> $O/ab.txt; step $v-$tag $?; }
for v in within late late within within late; do b $v small --sizes 1024,4096,16384,65536 --steps 300 --warmup 20; done
for v in within late; do b $v big --sizes 1048576 --steps 200 --warmup 20; done
for v in late within; do ((SECONDS < 400)) && b $v late3000 --sizes 1048576 --steps 100 --warmup 3000; done
for n in 1024 16384; do ((SECONDS < 500)) && { CUDA_INJECTION64_PATH=$B/lib/libflipflow_gpu_trace.so FLIPFLOW_GPU_TRACE=$O/trace-$n.csv timeout 40 $B/bin/pipeline bench $P/bench-abp.yaml --device cuda --sizes $n --steps 30 --warmup 20 > $O/trace-$n.txt 2>&1; step trace-$n $?; }; done
echo done t=$SECONDS >> $I; pack
