#!/bin/bash
# Session 21, call 5 (one H200), bundle of main 2ea0410: overlap_correct variants against main's
# plugin — lists (iteration 0's lists in their own kernel before the wide gather) and t192 (the
# grid kernel in blocks of 192 at 3 an SM): CUDA bit tests with each, then bench-abp at 2^20
# (early and after 3000 steps) and 2^14, interleaved.
set -u
SECONDS=0
tar -xzf gpu-carry/bundle-s21b.tar.gz
B=$PWD/bundle; O=/tmp/c5; rm -rf $O; mkdir -p $O
I=$O/info.txt
{ nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv; head -1 $B/.flipflow-bundle; } > $I
pack() { (cd /tmp && tar -czf $OUT/c5.tgz.part c5 && mv $OUT/c5.tgz.part $OUT/c5.tgz); }
step() { echo "$1 rc=$2 t=$SECONDS" >> $I; pack; }
for v in lists t192; do
  mkdir -p $B/$v/plugins && cp gpu-carry/lead/$v/plugins/*.so $B/$v/plugins/
  S=/tmp/sh-$v; rm -rf $S; mkdir -p $S/x
  for d in bin lib tests plugins test-plugins pipelines; do [[ -e $B/$d ]] && cp -a $B/$d $S/x/; done
  cp $B/.flipflow-bundle $S/x/ 2>/dev/null
  cp $B/$v/plugins/*.so $S/x/plugins/
  ln -s $S/x/lib $S/lib   # the variant's rpath is $ORIGIN/../../lib
  (cd $S/x && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 120 bin/run-tests test_overlap_correct_cpu_cuda test_overlap_correct test_overlap_correct_walls > $O/tests-$v.txt 2>&1; echo "rc=$?" >> $O/tests-$v.txt) &
done
wait
{ echo "tests: $(cat $O/tests-*.txt | grep -c "^PASS") PASS, $(cat $O/tests-*.txt | grep -c "^FAIL") FAIL"; grep -h "^FAIL" $O/tests-*.txt; } >> $I
step tests 0
P=$B/pipelines
b() { local v=$1 tag=$2; shift 2; pp=""; [[ $v != main ]] && pp=$B/$v/plugins
  FLIPFLOW_PLUGIN_PATH=$pp timeout 40 $B/bin/pipeline bench $P/bench-abp.yaml --device cuda "$@" 2>&1 | grep -E "^[0-9]|iterations per" | sed "s/^/$v $tag: /" >> $O/ab.txt; step $v-$tag $?; }
for v in main lists t192 t192 lists main; do b $v early --sizes 16384,1048576 --steps 200 --warmup 20; done
for v in main t192 lists; do ((SECONDS < 230)) && b $v late --sizes 1048576 --steps 100 --warmup 3000; done
echo done t=$SECONDS >> $I; pack
