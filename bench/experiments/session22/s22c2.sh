#!/bin/bash
# Session 22, call 2 (one H200), bundle of main 27cfc2d: overlap_correct's tail with superset marks
# (branch superset22: the tail's gathers mark the next candidates, no check after the apply)
# against main's plugin: CUDA bit tests with the variant, then bench-abp interleaved at small N,
# at 2^20 and at 2^20 after 3000 steps (the metrics must be equal: same iterations, pairs, correction).
set -u
SECONDS=0
tar -xzf gpu-carry/bundle-s22a.tar.gz
B=$PWD/bundle; O=/tmp/c2; rm -rf $O; mkdir -p $O
I=$O/info.txt
{ nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv; head -1 $B/.flipflow-bundle; } > $I
pack() { (cd /tmp && tar -czf $OUT/c2.tgz.part c2 && mv $OUT/c2.tgz.part $OUT/c2.tgz); }
step() { echo "$1 rc=$2 t=$SECONDS" >> $I; pack; }
v=ss
mkdir -p $B/$v/plugins && cp gpu-carry/ss22/plugins/*.so $B/$v/plugins/
S=/tmp/sh-$v; rm -rf $S; mkdir -p $S/x
for d in bin lib tests plugins test-plugins pipelines; do [[ -e $B/$d ]] && cp -a $B/$d $S/x/; done
cp $B/.flipflow-bundle $S/x/ 2>/dev/null
cp $B/$v/plugins/*.so $S/x/plugins/
ln -s $S/x/lib $S/lib
(cd $S/x && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 100 bin/run-tests test_overlap_correct test_overlap_correct_walls test_overlap_correct_determinism > $O/tests-a.txt 2>&1; echo "rc=$?" >> $O/tests-a.txt) &
(cd $S/x && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 100 bin/run-tests test_overlap_correct_cpu_cuda test_cpu_cuda_bits > $O/tests-b.txt 2>&1; echo "rc=$?" >> $O/tests-b.txt) &
wait
{ echo "tests: $(cat $O/tests-*.txt | grep -c "^PASS") PASS, $(cat $O/tests-*.txt | grep -c "^FAIL") FAIL"; grep -h "^FAIL" $O/tests-*.txt; } >> $I
step tests 0
P=$B/pipelines
b() { local v=$1 tag=$2; shift 2; pp=""; [[ $v != main ]] && pp=$B/$v/plugins
  FLIPFLOW_PLUGIN_PATH=$pp timeout 60 $B/bin/pipeline bench $P/bench-abp.yaml --device cuda "$@" 2>&1 | grep -E "^[0-9]|overlap_correct/" | sed "s/^/$v $tag: /" >> $O/ab.txt; step $v-$tag $?; }
for v in main ss ss main main ss; do b $v small --sizes 1024,4096,16384 --steps 300 --warmup 20; done
for v in main ss ss main; do b $v big --sizes 1048576 --steps 200 --warmup 20; done
for v in main ss; do ((SECONDS < 420)) && b $v late --sizes 1048576 --steps 100 --warmup 3000; done
echo done t=$SECONDS >> $I; pack
