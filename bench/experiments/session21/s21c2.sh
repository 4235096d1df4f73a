#!/bin/bash
# Session 21, call 2: delaunay.lawson skipping round 0's read at any count (4f46455) against
# 656d022's plugin: bits (CUDA tests with the variant in a shadow bundle), interleaved bench-abp
# throughput at small N, and a CUPTI trace of the variant with every runtime call at 2^10.
set -u
SECONDS=0
tar -xzf gpu-carry/bundle-s21.tar.gz
B=$PWD/bundle; O=/tmp/c2; rm -rf $O; mkdir -p $O
mkdir -p $B/law/plugins && cp gpu-carry/lead/law/plugins/*.so $B/law/plugins/
S=/tmp/shadow; rm -rf $S; mkdir -p $S
for d in bin lib tests plugins test-plugins pipelines; do [[ -e $B/$d ]] && cp -a $B/$d $S/; done
cp $B/.flipflow-bundle $S/ 2>/dev/null
cp $B/law/plugins/*.so $S/plugins/
# rpath $ORIGIN/../../lib -> in the shadow the plugin sits one level up: link lib one level up
ln -s $S/lib /tmp/lib 2>/dev/null
I=$O/info.txt
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv > $I
pack() { (cd /tmp && tar -czf $OUT/c2.tgz.part c2 && mv $OUT/c2.tgz.part $OUT/c2.tgz); }
step() { echo "$1 rc=$2 t=$SECONDS" >> $I; pack; }
(cd $S && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 150 bin/run-tests test_delaunay_lawson test_rollback test_cpu_cuda_bits test_graph_capture test_delaunay_flip > $O/tests-a.txt 2>&1; echo "rc=$?" >> $O/tests-a.txt) &
(cd $S && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 150 bin/run-tests test_boids_delaunay test_delaunay_detect_inversion test_rollback_restores test_neighbors_delaunay > $O/tests-b.txt 2>&1; echo "rc=$?" >> $O/tests-b.txt) &
wait
{ echo "tests: $(cat $O/tests-*.txt | grep -c "^PASS") PASS, $(cat $O/tests-*.txt | grep -c "^FAIL") FAIL"; grep -h "^FAIL" $O/tests-*.txt; } >> $I
step tests 0
P=$B/pipelines
for r in 1 2 3; do
  for v in main law; do
    pp=""; [[ $v == law ]] && pp=$B/law/plugins
    FLIPFLOW_PLUGIN_PATH=$pp timeout 40 $B/bin/pipeline bench $P/bench-abp.yaml --device cuda --sizes 1024,2048,4096,16384 --steps 500 --warmup 20 2>&1 | grep -E "^[0-9]|lawson_|iterations per" | sed "s/^/$v r$r: /" >> $O/ab.txt
    step ab-$v-$r $?
  done
done
FLIPFLOW_PLUGIN_PATH=$B/law/plugins FLIPFLOW_GPU_TRACE_API=all CUDA_INJECTION64_PATH=$B/lib/libflipflow_gpu_trace.so FLIPFLOW_GPU_TRACE=$O/trace-law-1024.csv timeout 40 $B/bin/pipeline bench $P/bench-abp.yaml --device cuda --sizes 1024 --steps 30 --warmup 20 > $O/trace-law-1024.txt 2>&1
step trace $?
echo done t=$SECONDS >> $I; pack
