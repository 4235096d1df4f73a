#!/bin/bash
# Session 20, last call (one H200): main e4e5bd4 (mgpu2 merged, count_gather): the one-GPU team
# cases and the overlap tests on CUDA, then overlap_correct at 2^20 against 2e93842's plugin.
set -u
SECONDS=0
export NCCL_NVLS_ENABLE=0
tar -xzf gpu-carry/bundle-s20g.tar.gz
B=$PWD/bundle; O=$OUT; mkdir -p $B/old/plugins; cp gpu-carry/mini/old/*.so $B/old/plugins/
head -1 $B/.flipflow-bundle > $O/info.txt
t() { (cd $B && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 120 bin/run-tests "$@" > $O/tests-$1.txt 2>&1); }
t test_overlap_correct_cpu_cuda & t test_overlap_correct_walls test_overlap_correct &
t test_decomposition test_decomposition_delaunay test_team test_neighbors_verlet test_overlap_correct_verlet &
wait; echo "tests t=$SECONDS" >> $O/info.txt; grep -h '^PASS\|^FAIL\|passed,' $O/tests-*.txt >> $O/info.txt
ab() { FLIPFLOW_PLUGIN_PATH=$2 timeout 45 $B/bin/pipeline bench $B/pipelines/bench-abp.yaml --device cuda --sizes 1048576 --steps 100 --warmup 20 2>&1 | grep -E '^1048576|iterations per' | sed "s/^/$1: /" >> $O/bench.txt; echo "$1 t=$SECONDS" >> $O/info.txt; }
ab new-1 ""; ab old-1 $B/old/plugins
((SECONDS < 140)) && { ab new-2 ""; ab old-2 $B/old/plugins; }
echo done t=$SECONDS >> $O/info.txt
