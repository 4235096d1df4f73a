#!/bin/bash
# Session 26, call 3 (one H200, bundle b26a of 72dbe32, every plugin a shadow): two variants of
# main b8bc5b0's overlap_correct, each against it, interleaved:
#   wn  - the wide path keeps next too (wide_gather writes it in iteration 0), so the cooperative
#         kernel's later iterations also skip the apply's grid barrier (2^17 and up);
#   t1k - a cluster's tail from an iteration that moved <= 1 024 particles (was 512).
# Their overlap tests on CUDA, then bench-abp 200 steps after 20 (small: three rounds; 2^18 and
# 2^20: two), and 2^20 100 steps after 3000 (two rounds).
# (It ran with its steps written out; they are call_lib.sh's suite and bench_abp now.)
#   carry: gpu-carry/b26a.tar.gz gpu-carry/v26main.tgz gpu-carry/v26wn.tgz gpu-carry/v26t1k.tgz
source tools/gpu/call_lib.sh c3 "$1"
for v in v26main v26wn v26t1k; do tar -xzf gpu-carry/$v.tgz -C gpu-carry; done
declare -A D=([main]=$(shadow main gpu-carry/v26main) [wn]=$(shadow wn gpu-carry/v26wn) [t1k]=$(shadow t1k gpu-carry/v26t1k))
for v in wn t1k; do
  TEST_TIMEOUT=200 tests ${D[$v]} $O/tests-$v-a.txt test_overlap_correct_cpu_cuda &
  TEST_TIMEOUT=200 tests ${D[$v]} $O/tests-$v-b.txt test_overlap_correct test_overlap_correct_walls \
    test_overlap_correct_determinism test_cpu_cuda_bits test_device_decisions &
done
wait
{ echo "tests: $(cat $O/tests-*.txt | grep -c "^PASS") PASS, $(cat $O/tests-*.txt | grep -c "^FAIL") FAIL"; grep -H "^FAIL" $O/tests-*.txt; } >> $I
step tests 0
for v in main t1k t1k main main t1k; do bench_abp $v small --sizes 1024,4096,8192,16384 --steps 200 --warmup 20; done
for v in main wn wn main; do bench_abp $v big --sizes 262144,1048576 --steps 200 --warmup 20; done
for v in wn main main wn; do bench_abp $v late --sizes 1048576 --steps 100 --warmup 3000; done
echo done t=$SECONDS >> $I; pack
