#!/bin/bash
# Session 21, call 6 (one H200), bundle of main 2ea0410: (1) helper tail21's request
# (gpu-carry/tail21/run.sh: overlap_correct's late iterations after 3000 steps); (2) the step
# parameters uploaded ahead (core of 9f5a2d1-ish, lib swapped into a copy of the bundle): CUDA
# tests with it, and bench-abp at 2^10 / 2^14 against the bundle's own core, interleaved.
set -u
SECONDS=0
tar -xzf gpu-carry/bundle-s21b.tar.gz
B=$PWD/bundle; O=/tmp/c6; rm -rf $O; mkdir -p $O
I=$O/info.txt
{ nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv; head -1 $B/.flipflow-bundle; } > $I
pack() { (cd /tmp && tar -czf $OUT/c6.tgz.part c6 && mv $OUT/c6.tgz.part $OUT/c6.tgz); }
step() { echo "$1 rc=$2 t=$SECONDS" >> $I; pack; }
timeout 185 bash gpu-carry/tail21/run.sh $B $O/tail21 > $O/tail21-run.txt 2>&1
step tail21 $?
R=/tmp/ringb; rm -rf $R; cp -a $B $R
cp gpu-carry/lead/ring/libflipflow.so $R/lib/libflipflow.so
cp gpu-carry/lead/ring/test_graph_capture $R/bin/test_graph_capture
(cd $R && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 100 bin/run-tests test_graph_capture test_cpu_cuda_bits test_rollback test_rollback_restores test_delaunay_lawson > $O/ring-tests.txt 2>&1; echo "rc=$?" >> $O/ring-tests.txt)
step ring-tests 0
for r in 1 2; do
  for v in main ring; do
    X=$B; [[ $v == ring ]] && X=$R
    timeout 30 $X/bin/pipeline bench $X/pipelines/bench-abp.yaml --device cuda --sizes 1024,16384 --steps 500 --warmup 20 2>&1 | grep -E "^[0-9]" | sed "s/^/$v r$r: /" >> $O/ring-ab.txt
    step ring-ab-$v-$r $?
  done
done
echo done t=$SECONDS >> $I; pack
