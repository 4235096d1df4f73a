#!/bin/bash
# Session 31, call 12: branch clus31 (core/backend/cuda/cluster.cuh: the cluster launch shape and
# occupancy check shared by overlap_correct's teams and Lawson's tail; host code only): the
# correction's and Lawson's CUDA tests, then bench-abp against main 185fd73's two plugins (v31f),
# two interleaved rounds (the same speed expected).
#   bash bench/experiments/session31/s31c12.sh gpu-carry/b31g.tar.gz
source tools/gpu/call_lib.sh c12 "$1"
tar -xzf gpu-carry/v31f.tgz -C /tmp
declare -A D=([clus]=$B [main]=$(shadow main /tmp/v31f))
TEST_TIMEOUT=150 tests $B $O/clus-tests.txt test_overlap_correct_cpu_cuda test_overlap_correct test_overlap_correct_determinism \
  test_delaunay_lawson test_cpu_cuda_bits test_device_decisions test_sweep
echo "clus tests: $(grep -c ^PASS $O/clus-tests.txt) PASS, $(grep -c ^FAIL $O/clus-tests.txt) FAIL" >> $I
step tests 0
for r in 1 2; do for v in main clus; do bench_abp $v r$r --sizes 1024,16384,65536 --steps 200 --warmup 20; done; done
echo done t=$SECONDS >> $I; pack
