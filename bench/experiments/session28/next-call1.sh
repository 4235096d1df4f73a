#!/bin/bash
# Prepared in session 28 for the next session's first call (not yet run): the whole CUDA suite on
# HEAD (65b7671's lane groups up to 128 particles a block ran only the correction's six test
# executables on a GPU, and the suite last ran on 5da40b9), the 64-run sweep row (its clusters of
# 8 take the same lane-group threshold), and bench-abp's rows, three rounds.
#   rm -rf bundle && tools/bundle build bundle && tar -cf - bundle | gzip -5 > gpu-carry/b29.tar.gz
#   bash bench/experiments/session28/next-call1.sh gpu-carry/b29.tar.gz      carry: the bundle
source tools/gpu/call_lib.sh n1 "$1"
declare -A D=([head]=$B)
suite $B
step suite 0
sweep_abp 1
sweep_abp 2
for r in 1 2 3; do bench_abp head small --sizes 1024,2048,4096,8192,16384,65536 --steps 200 --warmup 20; done
bench_abp head big --sizes 1048576 --steps 200 --warmup 20
bench_abp head late --sizes 1048576 --steps 100 --warmup 3000
echo done t=$SECONDS >> $I; pack
