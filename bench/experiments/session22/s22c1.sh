#!/bin/bash
# Session 22, call 1 (one H200): session 21's review mends on CUDA (may_capture, Lawson's `defer`,
# mark_word/mark_bit) on the bundle of main 27cfc2d while HOOMD-blue builds on the CPU cores; then
# bench-abp at 2^14 and 2^20 and HOOMD's ABP + WCA bench on the same machine (issue 20's HOOMD row).
set -u
SECONDS=0
tar -xzf gpu-carry/bundle-s22a.tar.gz
tar -xzf gpu-carry/hoomd-kit.tgz
B=$PWD/bundle; O=/tmp/c1; rm -rf $O; mkdir -p $O
I=$O/info.txt
{ nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv; head -1 $B/.flipflow-bundle; nproc; } > $I
pack() { (cd /tmp && tar -czf $OUT/c1.tgz.part c1 && mv $OUT/c1.tgz.part $OUT/c1.tgz); }
step() { echo "$1 rc=$2 t=$SECONDS" >> $I; pack; }
(OUT=$O bash hoomd-kit/build.sh 450 > $O/hoomd-build.txt 2>&1; echo "build rc=$? t=$SECONDS" >> $O/hoomd-build.txt) &
BP=$!
(cd $B && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 150 bin/run-tests test_graph_capture test_cpu_cuda_bits test_rollback test_rollback_restores test_delaunay_lawson test_overlap_correct test_overlap_correct_cpu_cuda test_overlap_correct_determinism > $O/tests.txt 2>&1); step tests $?
wait $BP; step hoomd-build 0
P=$B/pipelines
timeout 60 $B/bin/pipeline bench $P/bench-abp.yaml --device cuda --sizes 16384,1048576 --steps 200 --warmup 20 > $O/abp.txt 2>&1; step abp $?
((SECONDS < 520)) && { OUT=$O timeout $((585 - SECONDS)) bash hoomd-kit/run.sh --sizes 16384 1048576 --dts 2e-3 --max-seconds 8 > $O/hoomd-run.txt 2>&1; step hoomd-run $?; }
echo done t=$SECONDS >> $I; pack
