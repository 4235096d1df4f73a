#!/bin/bash
# Session 31, call 10: Lawson's tail on a cluster with consecutive elements spread over its blocks
# (branch lcli31: 16 blocks = the bundle b31e, v31cli16; 8 blocks: v31cli8), from 8 192 particles,
# gated launches up to 4 096 candidates, against main's plugin (v31pub): the cluster's tests, then
# bench-abp, three interleaved rounds.
#   bash bench/experiments/session31/s31c10.sh gpu-carry/b31e.tar.gz
source tools/gpu/call_lib.sh c10 "$1"
for v in pub cli8; do tar -xzf gpu-carry/v31$v.tgz -C /tmp; done
declare -A D=([main]=$(shadow main /tmp/v31pub) [cli16]=$B [cli8]=$(shadow cli8 /tmp/v31cli8))
TEST_TIMEOUT=240 tests $B $O/cli16-tests.txt test_delaunay_lawson test_cpu_cuda_bits test_device_decisions \
  test_delaunay_detect_inversion test_rollback test_rollback_stress
echo "cli16 tests: $(grep -c ^PASS $O/cli16-tests.txt) PASS, $(grep -c ^FAIL $O/cli16-tests.txt) FAIL" >> $I
step tests 0
for r in 1 2 3; do
  for v in main cli16 cli8; do bench_abp $v r$r --sizes 1024,8192,16384,32768,65536,131072,262144 --steps 200 --warmup 20; done
done
echo done t=$SECONDS >> $I; pack
