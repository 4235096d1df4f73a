#!/bin/bash
# Session 27, call 8 (bundle of e92304d, the correction as shadow plugins): branch redux27 (a72d451,
# warp_sum by redux.sync on three slices) against HEAD's plugin:
#   1. redux27's correction tests on CUDA (the CPU == CUDA bits among them);
#   2. bench-abp 200 steps after 20 at 2^10..2^16, three interleaved rounds; 2^20, one round each.
#   bash bench/experiments/session27/s27c8.sh BUNDLE.tar.gz      carry: the bundle, v27redux
source tools/gpu/call_lib.sh c8 "$1"
tar -xzf gpu-carry/v27redux.tgz -C /tmp
declare -A D=([head]=$B [redux]=$(shadow redux /tmp/v27redux))
TEST_TIMEOUT=200 tests ${D[redux]} $O/redux-tests.txt test_overlap_correct_cpu_cuda test_overlap_correct \
  test_overlap_correct_walls test_overlap_correct_determinism test_cpu_cuda_bits test_device_decisions
echo "redux: $(grep -c "^PASS" $O/redux-tests.txt) PASS, $(grep -c "^FAIL" $O/redux-tests.txt) FAIL" >> $I
step redux-tests 0
for v in head redux redux head head redux; do bench_abp $v small --sizes 1024,4096,8192,16384,65536 --steps 200 --warmup 20; done
for v in redux head; do bench_abp $v big --sizes 1048576 --steps 200 --warmup 20; done
echo done t=$SECONDS >> $I; pack
