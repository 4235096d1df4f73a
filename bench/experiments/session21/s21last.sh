#!/bin/bash
# Session 21, last call (one H200), bundle of main b605eef (tail21's batched tail check merged):
# the CPU == CUDA overlap tests, then bench-abp 2^20 after 3000 steps, 23db6ab's plugin ("prev")
# and b605eef's, one run each.
set -u
SECONDS=0
tar -xzf gpu-carry/bundle-last21.tar.gz
B=$PWD/bundle; O=/tmp/l; rm -rf $O; mkdir -p $O
I=$O/info.txt
{ nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv; head -1 $B/.flipflow-bundle; } > $I
pack() { (cd /tmp && tar -czf $OUT/l.tgz.part l && mv $OUT/l.tgz.part $OUT/l.tgz); }
step() { echo "$1 rc=$2 t=$SECONDS" >> $I; pack; }
(cd $B && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 80 bin/run-tests test_overlap_correct_cpu_cuda > $O/tests-a.txt 2>&1; echo "rc=$?" >> $O/tests-a.txt) &
(cd $B && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 80 bin/run-tests test_overlap_correct test_overlap_correct_walls test_overlap_correct_determinism > $O/tests-b.txt 2>&1; echo "rc=$?" >> $O/tests-b.txt) &
wait
{ echo "tests: $(cat $O/tests-*.txt | grep -c "^PASS") PASS, $(cat $O/tests-*.txt | grep -c "^FAIL") FAIL"; grep -h "^FAIL" $O/tests-*.txt; } >> $I
step tests 0
mkdir -p $B/prev/plugins && cp gpu-carry/lead/prev/plugins/*.so $B/prev/plugins/
for v in prev last; do
  pp=""; [[ $v == prev ]] && pp=$B/prev/plugins
  ((SECONDS < 150)) && { FLIPFLOW_PLUGIN_PATH=$pp timeout 40 $B/bin/pipeline bench $B/pipelines/bench-abp.yaml --device cuda --sizes 1048576 --steps 100 --warmup 3000 > $O/abp3000-$v.txt 2>&1; step abp3000-$v $?; }
done
echo done t=$SECONDS >> $I; pack
