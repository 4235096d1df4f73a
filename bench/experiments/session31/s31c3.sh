#!/bin/bash
# Session 31, call 3: detect's last block and Lawson's tail kernel publishing from registers
# (branch lpub31, plugin v31pub) against main's plugin: the Delaunay CUDA tests, then bench-abp,
# three interleaved rounds.
#   bash bench/experiments/session31/s31c3.sh gpu-carry/b31a.tar.gz gpu-carry/v31pub.tgz
source tools/gpu/call_lib.sh c3 "$1"
tar -xzf "$2" -C /tmp
declare -A D=([main]=$B [pub]=$(shadow pub /tmp/v31pub))
tests ${D[pub]} $O/pub-tests.txt test_delaunay_lawson test_delaunay_detect_inversion test_cpu_cuda_bits \
  test_device_decisions test_delaunay_flip test_delaunay_tries test_rollback
step tests 0
for r in 1 2 3; do
  for v in main pub; do bench_abp $v r$r --sizes 1024,4096,16384,65536 --steps 200 --warmup 20; done
done
echo "pub tests: $(grep -c ^PASS $O/pub-tests.txt) PASS, $(grep -c ^FAIL $O/pub-tests.txt) FAIL" >> $I
echo done t=$SECONDS >> $I; pack
