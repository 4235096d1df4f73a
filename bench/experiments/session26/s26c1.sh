#!/bin/bash
# Session 26, call 1 (one H200, bundle b26a of main 72dbe32, whose last CUDA change is 95e2846):
# the whole CUDA suite in six groups at once (as s25c5.sh), test_out_of_memory alone after them;
# then branch fused25's plugin (session 25's next-fused-check.sh: its overlap tests, and bench-abp
# 200 steps after 20 interleaved with main at 2^10..2^16, three rounds); then session 25's
# next-ncu-tail.sh (ncu stall sampling of the correction at 2^10 and 2^14). (It ran with these
# steps written out; they are call_lib.sh's suite, bench_abp and ncu_correction now.)
#   carry: gpu-carry/b26a.tar.gz gpu-carry/v26fused.tgz
source tools/gpu/call_lib.sh c1 "$1"
suite $B
step suite 0
tar -xzf gpu-carry/v26fused.tgz -C gpu-carry
declare -A D=([main]=$B [fused]=$(shadow fused gpu-carry/v26fused))
TEST_TIMEOUT=200 tests ${D[fused]} $O/tests-fused.txt test_overlap_correct_cpu_cuda test_overlap_correct \
  test_overlap_correct_walls test_overlap_correct_determinism test_cpu_cuda_bits test_device_decisions
step tests-fused 0
for v in main fused fused main main fused; do bench_abp $v small --sizes 1024,4096,8192,16384,65536 --steps 200 --warmup 20; done
ncu_correction 1024 16384
echo done t=$SECONDS >> $I; pack
