#!/bin/bash
# Session 31, call 8: small launches at small N: the overdamped integrators' loop in blocks of 64
# (v31ov64, the abp plugin) and detect's marking in blocks of 64 up to 49 152 edges (v31mk64, the
# delaunay plugin, on main 8925864), alone and together, against main's plugins (v31pub and the
# bundle's abp): tests, then bench-abp, three interleaved rounds, and 2^20 once.
#   bash bench/experiments/session31/s31c8.sh gpu-carry/b31c.tar.gz
source tools/gpu/call_lib.sh c8 "$1"
for v in pub ov64 mk64; do tar -xzf gpu-carry/v31$v.tgz -C /tmp; done
mkdir -p /tmp/v31both /tmp/v31ovp && cp /tmp/v31ov64/*.so /tmp/v31mk64/*.so /tmp/v31both/ && cp /tmp/v31ov64/*.so /tmp/v31pub/*.so /tmp/v31ovp/
declare -A D=([main]=$(shadow main /tmp/v31pub) [ov64]=$(shadow ov64 /tmp/v31ovp) [mk64]=$(shadow mk64 /tmp/v31mk64) [both]=$(shadow both /tmp/v31both))
TEST_TIMEOUT=200 tests ${D[both]} $O/both-tests.txt test_cpu_cuda_bits test_device_decisions test_delaunay_detect_inversion \
  test_abp_integrate test_abp_non_finite test_rollback
echo "both tests: $(grep -c ^PASS $O/both-tests.txt) PASS, $(grep -c ^FAIL $O/both-tests.txt) FAIL" >> $I
step tests 0
for r in 1 2 3; do
  for v in main ov64 mk64 both; do bench_abp $v r$r --sizes 1024,4096,16384,65536 --steps 200 --warmup 20; done
done
for v in main both; do bench_abp $v big --sizes 1048576 --steps 100 --warmup 20; done
echo done t=$SECONDS >> $I; pack
