#!/bin/bash
# For the next session (not run): where Lawson's gated launch should switch to a grid round first.
# Session 32 (a8e477e) runs the grid round first when the last run flipped more than a pass of the
# tail kernel (16 384 on the cluster, 1 024 in one block): only 2^20 (~19 000 flips) does. The tail
# kernel alone with ~18 000 candidates lost 1.3 % at 2^20 (session 32, call 1); what about ~4 600
# (2^18) and ~9 000 (2^19), and ~290 in one block (2^14)? Each variant is main + one patch, its
# delaunay plugin as /tmp/v33X/libflipflow_stage_delaunay.so (the mkvar recipe,
# bench/experiments/README.md):
#   v33h  next-lawson-grid-first-half-pass.patch     (grid round first above half a pass: 2^19, 2^20)
#   v33q  next-lawson-grid-first-quarter-pass.patch  (above a quarter: 2^14's one block, 2^18-2^20)
#   bash bench/experiments/session32/next-call1.sh gpu-carry/BUNDLE.tar.gz   carry: the bundle, v33h, v33q
source tools/gpu/call_lib.sh "${2:-n1}" "$1"  # session 33 ran it as call c2 (s33c2.sh)
declare -A D=([main]=$B)
for v in h q; do tar -xzf gpu-carry/v33$v.tgz -C /tmp; D[$v]=$(shadow $v /tmp/v33$v); done
for v in h q; do
  TEST_TIMEOUT=200 tests ${D[$v]} $O/$v-tests.txt test_delaunay_lawson test_cpu_cuda_bits test_device_decisions &
done
wait
for v in h q; do echo "$v tests: $(grep -c ^PASS $O/$v-tests.txt) PASS, $(grep -c ^FAIL $O/$v-tests.txt) FAIL" >> $I; done
step tests 0
for r in 1 2 3; do
  for v in main h q; do bench_abp $v r$r --sizes 16384,131072,262144,524288 --steps 200 --warmup 20; done
done
for v in main h q main h q; do bench_abp $v m20 --sizes 1048576 --steps 200 --warmup 20; done
echo done t=$SECONDS >> $I; pack
