#!/bin/bash
# Session 26, call 2 (one H200, bundle b26a of main 72dbe32): branch bar26 (the tail's counters by
# iteration parity, its sums by shared atomics, no apply barrier without walls) against main
# 8ad095d's plugin (fused25 merged), both as shadow plugins: bar26's overlap tests on CUDA, then
# bench-abp 200 steps after 20 at 2^10..2^16 (three rounds), 2^20 (one round each), and 2^20 100
# steps after 3000 (one each), interleaved.
# (It ran with its steps written out; they are call_lib.sh's suite and bench_abp now.)
#   carry: gpu-carry/b26a.tar.gz gpu-carry/v26fused.tgz gpu-carry/v26bar.tgz
source tools/gpu/call_lib.sh c2 "$1"
for v in v26fused v26bar; do tar -xzf gpu-carry/$v.tgz -C gpu-carry; done
declare -A D=([main]=$(shadow main gpu-carry/v26fused) [bar]=$(shadow bar gpu-carry/v26bar))
TEST_TIMEOUT=200 tests ${D[bar]} $O/tests-a.txt test_overlap_correct_cpu_cuda test_cpu_cuda_bits &
TEST_TIMEOUT=200 tests ${D[bar]} $O/tests-b.txt test_overlap_correct test_overlap_correct_walls \
  test_overlap_correct_determinism test_device_decisions test_hard_disk_eos &
wait
{ echo "tests: $(cat $O/tests-[ab].txt | grep -c "^PASS") PASS, $(cat $O/tests-[ab].txt | grep -c "^FAIL") FAIL"; cat $O/tests-[ab].txt | grep "^FAIL"; } >> $I
step tests 0
for v in main bar bar main main bar; do bench_abp $v small --sizes 1024,4096,8192,16384,65536 --steps 200 --warmup 20; done
for v in bar main; do bench_abp $v big --sizes 1048576 --steps 200 --warmup 20; done
for v in main bar; do bench_abp $v late --sizes 1048576 --steps 100 --warmup 3000; done
echo done t=$SECONDS >> $I; pack
