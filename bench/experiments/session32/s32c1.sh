#!/bin/bash
# Session 32, call 1: the whole CUDA suite on main 303f1ba (the 62 executables session 31 did not
# re-run after 2dea886), then session 31's next-call1.sh: Lawson's tail cluster of 4 / 8 from
# 8 192 particles (v32c4, v32c8) at 2^12-2^15, and gated launches up to 16 384 / 32 768 candidates
# (v32g16, v32g32) at 2^17-2^20, each main + one patch of bench/experiments/session31.
#   bash bench/experiments/session32/s32c1.sh gpu-carry/b32a.tar.gz   carry: b32a, v32c4, v32c8, v32g16, v32g32
source tools/gpu/call_lib.sh c1 "$1"
suite "$B" 200
step suite 0
declare -A D=([main]=$B)
for v in c4 c8 g16 g32; do tar -xzf gpu-carry/v32$v.tgz -C /tmp; D[$v]=$(shadow $v /tmp/v32$v); done
for v in c4 c8 g16 g32; do
  TEST_TIMEOUT=200 tests ${D[$v]} $O/$v-tests.txt test_delaunay_lawson test_cpu_cuda_bits test_device_decisions &
done
wait
for v in c4 c8 g16 g32; do echo "$v tests: $(grep -c ^PASS $O/$v-tests.txt) PASS, $(grep -c ^FAIL $O/$v-tests.txt) FAIL" >> $I; done
step tests 0
for r in 1 2 3; do
  for v in main c4 c8; do bench_abp $v r$r --sizes 4096,8192,16384,32768 --steps 200 --warmup 20; done
  for v in main g16; do bench_abp $v big$r --sizes 131072,262144,524288 --steps 200 --warmup 20; done
done
for v in main g16 g32 main g32; do bench_abp $v m20 --sizes 1048576 --steps 200 --warmup 20; done
echo done t=$SECONDS >> $I; pack
