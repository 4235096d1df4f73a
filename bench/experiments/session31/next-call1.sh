#!/bin/bash
# For the next session (not run): Lawson's tail cluster at its edges. Session 31 kept the cluster of
# 16 from 32 768 particles (2^13 −3.7 %, 2^14 −0.7 %, 2^15-2^17 +4.7 / +9.2 / +6.1 %); what a
# smaller cluster does at 2^13-2^14 (fewer blocks: cheaper barriers, still spread stores), and
# what gated launches up to 16 384 candidates do at 2^18-2^19 (~4 600 / ~9 000 candidates a step,
# now decided on the host). Each variant is main + one patch, its delaunay plugin as
# /tmp/v32X/libflipflow_stage_delaunay.so (the mkvar recipe, bench/experiments/README.md):
#   v32c4  next-lawson-cluster4-from-8192.patch   (a cluster of 4 from 8 192 particles)
#   v32c8  next-lawson-cluster8-from-8192.patch   (a cluster of 8 from 8 192 particles)
#   v32g16 next-lawson-gate-16384.patch           (kGatedCandidates = kTailMarked = kTailRound0 = 16 384)
#   v32g32 next-lawson-gate-32768.patch           (the same at 32 768: 2^20's ~18 000 candidates a step
#                                                   decided on the device, round 0 in two passes)
#   bash bench/experiments/session31/next-call1.sh gpu-carry/BUNDLE.tar.gz   carry: the bundle, v32c4, v32c8, v32g16, v32g32
source tools/gpu/call_lib.sh n1 "$1"
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
