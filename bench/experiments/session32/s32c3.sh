#!/bin/bash
# Session 32, call 3: main 7e0d8f7 (overlap_correct's take_gather: the grid kernel's and the shared
# tail's takes through one helper; the cubin differs in three Mark instantiations' registers) —
# the correction's six CUDA test executables, then bench-abp against 42c0c53's overlap_correct
# plugin (v32oc) in the same bundle; then the closing numbers: after 3 000 steps at 2^20 and
# the 64-run sweep.
#   bash bench/experiments/session32/s32c3.sh gpu-carry/b32c.tar.gz   carry: b32c, v32oc
source tools/gpu/call_lib.sh c3 "$1"
tar -xzf gpu-carry/v32oc.tgz -C /tmp
declare -A D=([new]=$B [start]=$(shadow start /tmp/v32oc))
TEST_TIMEOUT=240 correction_tests new
for r in 1 2 3; do
  for v in start new; do bench_abp $v r$r --sizes 1024,2048,4096,16384,65536 --steps 200 --warmup 20; done
done
for v in start new start new; do bench_abp $v m20 --sizes 1048576 --steps 200 --warmup 20; done
bench_abp new late --sizes 1048576 --steps 100 --warmup 3000
sweep_abp 1
echo done t=$SECONDS >> $I; pack
