#!/bin/bash
# Session 22, call 3 (one H200), bundle of main 27cfc2d: two variants against main's plugins.
#   fold  (branch fold22, delaunay plugin): Lawson's round 0 marked by the tail kernel itself when
#         the read is deferred and there are at most 1024 candidates (one launch fewer at small N);
#   ccref (branch ccref22, overlap plugin): check_listed shared by thread_check and claim_checked.
# CUDA tests with each (shadow bundles), then bench-abp interleaved; metrics must be equal.
set -u
SECONDS=0
tar -xzf gpu-carry/bundle-s22a.tar.gz
B=$PWD/bundle; O=/tmp/c3; rm -rf $O; mkdir -p $O
I=$O/info.txt
{ nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv; head -1 $B/.flipflow-bundle; } > $I
pack() { (cd /tmp && tar -czf $OUT/c3.tgz.part c3 && mv $OUT/c3.tgz.part $OUT/c3.tgz); }
step() { echo "$1 rc=$2 t=$SECONDS" >> $I; pack; }
declare -A TESTS=(
  [fold]="test_delaunay_lawson test_cpu_cuda_bits test_rollback test_rollback_restores test_boids_delaunay test_graph_capture test_delaunay_flip test_delaunay_detect_inversion"
  [ccref]="test_overlap_correct test_overlap_correct_walls test_overlap_correct_determinism test_overlap_correct_cpu_cuda")
for v in fold ccref; do
  src=gpu-carry/${v}22/plugins
  mkdir -p $B/$v/plugins && cp $src/*.so $B/$v/plugins/
  S=/tmp/sh-$v; rm -rf $S; mkdir -p $S/x
  for d in bin lib tests plugins test-plugins pipelines; do [[ -e $B/$d ]] && cp -a $B/$d $S/x/; done
  cp $B/.flipflow-bundle $S/x/ 2>/dev/null
  cp $B/$v/plugins/*.so $S/x/plugins/
  ln -s $S/x/lib $S/lib
  (cd $S/x && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 120 bin/run-tests ${TESTS[$v]} > $O/tests-$v.txt 2>&1; echo "rc=$?" >> $O/tests-$v.txt) &
done
wait
{ echo "tests: $(cat $O/tests-*.txt | grep -c "^PASS") PASS, $(cat $O/tests-*.txt | grep -c "^FAIL") FAIL"; grep -h "^FAIL" $O/tests-*.txt; } >> $I
step tests 0
P=$B/pipelines
b() { local v=$1 tag=$2; shift 2; pp=""; [[ $v != main ]] && pp=$B/$v/plugins
  FLIPFLOW_PLUGIN_PATH=$pp timeout 60 $B/bin/pipeline bench $P/bench-abp.yaml --device cuda "$@" 2>&1 | grep -E "^[0-9]|overlap_correct/|lawson/" | sed "s/^/$v $tag: /" >> $O/ab.txt; step $v-$tag $?; }
for v in main fold ccref ccref fold main main fold ccref; do b $v small --sizes 1024,4096,16384 --steps 300 --warmup 20; done
for v in main ccref fold fold ccref main; do b $v big --sizes 1048576 --steps 200 --warmup 20; done
for v in main ccref; do ((SECONDS < 440)) && b $v late --sizes 1048576 --steps 100 --warmup 3000; done
echo done t=$SECONDS >> $I; pack
