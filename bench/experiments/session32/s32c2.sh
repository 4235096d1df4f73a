#!/bin/bash
# Session 32, call 2: main 42c0c53 (lawson_tail_pass: Lawson's gate, round 0 and tail limit one
# pass of its tail kernel) — its Delaunay, bits and device-decision tests, then bench-abp against
# 303f1ba's delaunay plugin (v32main) in the same bundle, and Carter side by side.
#   bash bench/experiments/session32/s32c2.sh gpu-carry/b32b.tar.gz   carry: b32b, v32main, peers-bundle.tar.gz
source tools/gpu/call_lib.sh c2 "$1"
tar -xzf gpu-carry/v32main.tgz -C /tmp
declare -A D=([new]=$B [start]=$(shadow start /tmp/v32main))
TEST_TIMEOUT=300 tests $B $O/tests-a.txt test_cpu_cuda_bits &
TEST_TIMEOUT=300 tests $B $O/tests-b.txt test_delaunay_lawson test_delaunay_detect_inversion test_device_decisions test_delaunay_flip &
wait
echo "tests: $(cat $O/tests-[ab].txt | grep -c ^PASS) PASS, $(cat $O/tests-[ab].txt | grep -c ^FAIL) FAIL; $(grep -h ^rc= $O/tests-[ab].txt | tr '\n' ' ')" >> $I
step tests 0
for r in 1 2 3; do
  for v in start new; do bench_abp $v r$r --sizes 1024,16384,65536,131072,262144,524288 --steps 200 --warmup 20; done
done
for v in start new start new; do bench_abp $v m20 --sizes 1048576 --steps 200 --warmup 20; done
mkdir -p /tmp/pb && tar -xzf gpu-carry/peers-bundle.tar.gz -C /tmp/pb
((SECONDS < 480)) && { timeout $((580 - SECONDS)) bash bench/carter_side_by_side.sh $B /tmp/pb/bundle $O/carter small > $O/carter-run.txt 2>&1; step carter $?; }
echo done t=$SECONDS >> $I; pack
