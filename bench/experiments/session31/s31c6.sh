#!/bin/bash
# Session 31, call 6: warp-aggregated appends in delaunay.lawson (append_index_warp) with the tail
# on a cluster of 16 from 8 192 particles (v31agg16 = lcl31), in one block at every size with
# gated launches up to 4 096 candidates (v31agg1), and on main's launch shapes (v31aggm = main +
# the aggregation), against main 8925864's plugin (v31pub): the Delaunay CUDA tests of each, clocks
# are not in these; bench-abp, three interleaved rounds.
#   bash bench/experiments/session31/s31c6.sh gpu-carry/b31c.tar.gz
source tools/gpu/call_lib.sh c6 "$1"
declare -A D
for v in pub agg16 agg1 aggm; do tar -xzf gpu-carry/v31$v.tgz -C /tmp; D[$v]=$(shadow $v /tmp/v31$v); done
for v in agg16 agg1 aggm; do
  TEST_TIMEOUT=200 tests ${D[$v]} $O/$v-tests.txt test_delaunay_lawson test_cpu_cuda_bits test_device_decisions \
    test_delaunay_flip test_rollback &
done
wait
for v in agg16 agg1 aggm; do echo "$v tests: $(grep -c ^PASS $O/$v-tests.txt) PASS, $(grep -c ^FAIL $O/$v-tests.txt) FAIL" >> $I; done
step tests 0
for r in 1 2 3; do
  for v in pub agg16 agg1 aggm; do bench_abp $v r$r --sizes 1024,4096,8192,16384,65536,262144 --steps 200 --warmup 20; done
done
echo done t=$SECONDS >> $I; pack
