#!/bin/bash
# Session 26, call 5 (one H200, bundle b26a of 72dbe32 with overlap_correct as shadow plugins; the
# other plugins are HEAD's):
#   1. the whole CUDA suite with HEAD e78df67's overlap_correct (fused25 and the tail's two
#      barriers) in six groups, t256's correction tests as a seventh, test_out_of_memory after;
#   2. t256 (the tail from an iteration that moved <= 256 particles instead of 512, cluster and
#      grid) against HEAD, bench-abp 200 steps after 20 at 2^10..2^16 (three rounds), 2^20 (one).
# (It ran with its steps written out; they are call_lib.sh's suite and bench_abp now.)
#   carry: gpu-carry/b26a.tar.gz gpu-carry/v26head.tgz gpu-carry/v26t256.tgz
source tools/gpu/call_lib.sh c5 "$1"
for v in v26head v26t256; do tar -xzf gpu-carry/$v.tgz -C gpu-carry; done
declare -A D=([head]=$(shadow head gpu-carry/v26head) [t256]=$(shadow t256 gpu-carry/v26t256))
H=${D[head]}
TEST_TIMEOUT=200 tests ${D[t256]} $O/t256-tests.txt test_overlap_correct_cpu_cuda test_overlap_correct \
  test_overlap_correct_walls test_overlap_correct_determinism test_cpu_cuda_bits &
t256=$!
suite $H
wait $t256
echo "t256: $(grep -c "^PASS" $O/t256-tests.txt) PASS, $(grep -c "^FAIL" $O/t256-tests.txt) FAIL" >> $I
step suite 0
for v in head t256 t256 head head t256; do bench_abp $v small --sizes 1024,4096,8192,16384,65536 --steps 200 --warmup 20; done
for v in t256 head; do bench_abp $v big --sizes 1048576 --steps 200 --warmup 20; done
echo done t=$SECONDS >> $I; pack
