#!/bin/bash
# Session 43, call 10: branch vedge43 (a flip reads its two vertex edges before its stores, not
# behind them) against main 38e13f2's bundle (b43b: the packed stores already): its delaunay plugin
# in a shadow bundle. The Delaunay, bits and rollback CUDA test executables, then bench-abp main /
# vl at 2^10, 2^14, 2^16 and 2^20, three interleaved rounds.
#   bash bench/experiments/session43/s43c10.sh gpu-carry/b43b.tar.xz    carry: gpu-carry
source tools/gpu/call_lib.sh "${2:-s43c10}" "$1"
mkdir -p /tmp/vl && tar -xJf gpu-carry/vl.tar.xz -C /tmp/vl
declare -A D=([main]=$B [vl]=$(shadow vl /tmp/vl))
TEST_TIMEOUT=240 tests "${D[vl]}" "$O/vl-tests.txt" test_delaunay_lawson test_delaunay_flip test_delaunay_detect_inversion \
  test_delaunay_tries test_cpu_cuda_bits test_boids_delaunay test_rollback test_rollback_restores test_device_decisions \
  test_graph_capture test_neighbors_delaunay test_delaunay_check
echo "vl: $(grep -c "^PASS" $O/vl-tests.txt) PASS, $(grep -c "^FAIL" $O/vl-tests.txt) FAIL" >> $I
step tests 0
for r in 1 2 3; do for v in main vl; do bench_abp $v r$r --sizes 1024,16384,65536,1048576 --steps 200 --warmup 20; done; done
echo done t=$SECONDS >> $I; pack
