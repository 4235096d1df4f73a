#!/bin/bash
# Session 32, call 4: main a8e477e (detect_inversion's gate opens for every listed Lawson
# candidate; Lawson's gated launch runs a grid round first after a run of more flips than a pass
# of its tail kernel) — its Delaunay, bits, decisions, rollback and sweep tests, then bench-abp
# against 7e0d8f7's delaunay plugin (v32d0) in the same bundle, and after 3 000 steps at 2^20.
#   bash bench/experiments/session32/s32c4.sh gpu-carry/b32d.tar.gz   carry: b32d, v32d0
source tools/gpu/call_lib.sh c4 "$1"
tar -xzf gpu-carry/v32d0.tgz -C /tmp
declare -A D=([new]=$B [start]=$(shadow start /tmp/v32d0))
TEST_TIMEOUT=300 tests $B $O/tests-a.txt test_cpu_cuda_bits &
TEST_TIMEOUT=300 tests $B $O/tests-b.txt test_delaunay_lawson test_delaunay_detect_inversion test_device_decisions test_delaunay_flip &
TEST_TIMEOUT=300 tests $B $O/tests-c.txt test_rollback test_rollback_restores test_rollback_stress test_graph_capture test_sweep &
wait
echo "tests: $(cat $O/tests-[abc].txt | grep -c ^PASS) PASS, $(cat $O/tests-[abc].txt | grep -c ^FAIL) FAIL; $(grep -h ^rc= $O/tests-[abc].txt | tr '\n' ' ')" >> $I
step tests 0
for r in 1 2 3; do
  for v in start new; do bench_abp $v r$r --sizes 1024,16384,65536,262144,524288 --steps 200 --warmup 20; done
done
for v in start new start new; do bench_abp $v m20 --sizes 1048576 --steps 200 --warmup 20; done
for v in new start; do bench_abp $v late --sizes 1048576 --steps 100 --warmup 3000; done
echo done t=$SECONDS >> $I; pack
