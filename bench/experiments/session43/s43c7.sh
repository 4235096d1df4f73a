#!/bin/bash
# Session 43, call 7: branch flipstore43 (a flip's two records and two opposite vertices in one
# 16-byte and one 8-byte store on the device; quad()'s records in one load): its delaunay plugin
# in a shadow bundle. The Delaunay, bits and rollback CUDA test executables, then bench-abp main /
# fs at 2^10, 2^14, 2^16 and 2^20, three interleaved rounds.
#   bash bench/experiments/session43/s43c7.sh gpu-carry/b43a.tar.xz    carry: gpu-carry
source tools/gpu/call_lib.sh "${2:-s43c7}" "$1"
mkdir -p /tmp/fs && tar -xJf gpu-carry/fs.tar.xz -C /tmp/fs
declare -A D=([main]=$B [fs]=$(shadow fs /tmp/fs))
TEST_TIMEOUT=240 tests "${D[fs]}" "$O/fs-tests.txt" test_delaunay_lawson test_delaunay_flip test_delaunay_detect_inversion \
  test_delaunay_tries test_cpu_cuda_bits test_boids_delaunay test_rollback test_rollback_restores test_device_decisions \
  test_graph_capture test_neighbors_delaunay test_delaunay_check
echo "fs: $(grep -c "^PASS" $O/fs-tests.txt) PASS, $(grep -c "^FAIL" $O/fs-tests.txt) FAIL" >> $I
step tests 0
for r in 1 2 3; do for v in main fs; do bench_abp $v r$r --sizes 1024,16384,65536,1048576 --steps 200 --warmup 20; done; done
echo done t=$SECONDS >> $I; pack
