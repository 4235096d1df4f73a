#!/bin/bash
# Session 31, call 4: Lawson's tail on a cluster of 16 from 8 192 particles, gated launches up to
# 4 096 candidates (branch lcl31, bundle b31c), against main 8925864's delaunay plugin (v31pub) in
# the same bundle: the Delaunay CUDA tests, then bench-abp, three interleaved rounds.
#   bash bench/experiments/session31/s31c4.sh gpu-carry/b31c.tar.gz gpu-carry/v31pub.tgz
source tools/gpu/call_lib.sh c4 "$1"
tar -xzf "$2" -C /tmp
declare -A D=([cl]=$B [main]=$(shadow main /tmp/v31pub))
TEST_TIMEOUT=240 tests $B $O/cl-tests.txt test_delaunay_lawson test_cpu_cuda_bits test_device_decisions \
  test_delaunay_detect_inversion test_delaunay_flip test_rollback test_rollback_stress
echo "cl tests: $(grep -c ^PASS $O/cl-tests.txt) PASS, $(grep -c ^FAIL $O/cl-tests.txt) FAIL" >> $I
step tests 0
for r in 1 2 3; do
  for v in main cl; do bench_abp $v r$r --sizes 2048,8192,16384,32768,65536,131072,262144 --steps 200 --warmup 20; done
done
for v in main cl; do bench_abp $v big --sizes 1048576 --steps 100 --warmup 20; done
echo done t=$SECONDS >> $I; pack
