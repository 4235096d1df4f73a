#!/bin/bash
# Session 22, call 5 (one H200), bundle of branch defer22 (overlap_correct's read waits on its own
# fence): the tests call 4 failed or did not reach, bench-abp within / late interleaved, traces.
set -u
SECONDS=0
tar -xzf gpu-carry/bundle-s22e.tar.gz
B=$PWD/bundle; O=/tmp/c5; rm -rf $O; mkdir -p $O
I=$O/info.txt
{ nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv; head -1 $B/.flipflow-bundle; } > $I
pack() { (cd /tmp && tar -czf $OUT/c5.tgz.part c5 && mv $OUT/c5.tgz.part $OUT/c5.tgz); }
step() { echo "$1 rc=$2 t=$SECONDS" >> $I; pack; }
T() { (cd $B && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 100 bin/run-tests "$@" > $O/tests-$1.txt 2>&1; echo "rc=$?" >> $O/tests-$1.txt) & }
T test_overlap_correct_cpu_cuda
T test_checkpoint test_delaunay_lawson
T test_cpu_cuda_bits test_overlap_correct test_sweep test_graph_capture
wait
{ echo "tests: $(cat $O/tests-*.txt | grep -c "^PASS") PASS, $(cat $O/tests-*.txt | grep -c "^FAIL") FAIL"; grep -h "^FAIL" $O/tests-*.txt; } >> $I
step tests 0
P=$B/pipelines
b() { local v=$1 tag=$2; shift 2; local e=1; [[ $v == within ]] && e=0
  FLIPFLOW_DEFERRED_READS=$e timeout 60 $B/bin/pipeline bench $P/bench-abp.yaml --device cuda "$@" 2>&1 | grep -E "^[0-9]|overlap_correct/" | sed "s/^/$v $tag: /" >> $O/ab.txt; step $v-$tag $?; }
for v in within late late within within late; do b $v small --sizes 1024,4096,16384 --steps 300 --warmup 20; done
for n in 1024 16384; do CUDA_INJECTION64_PATH=$B/lib/libflipflow_gpu_trace.so FLIPFLOW_GPU_TRACE=$O/trace-$n.csv timeout 30 $B/bin/pipeline bench $P/bench-abp.yaml --device cuda --sizes $n --steps 30 --warmup 20 > $O/trace-$n.txt 2>&1; step trace-$n $?; done
((SECONDS < 200)) && b late big --sizes 1048576 --steps 200 --warmup 20
echo done t=$SECONDS >> $I; pack
