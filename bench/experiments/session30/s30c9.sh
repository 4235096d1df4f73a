#!/bin/bash
# Session 30, call 9: main at 2e896b5 (blk30 merged: the shared-memory tail): the whole CUDA suite,
# then bench-abp's rows (three rounds of 2^10-2^16, 2^20, 100 steps after 3 000 at 2^20) and the
# 64-run sweep twice.
#   bash bench/experiments/session30/s30c9.sh gpu-carry/b30f.tar.gz    carry: the bundle
source tools/gpu/call_lib.sh c9 "$1"
declare -A D=([head]=$B)
suite $B 270
step suite 0
for r in 1 2 3; do bench_abp head small --sizes 1024,2048,4096,8192,16384,65536 --steps 200 --warmup 20; done
bench_abp head big --sizes 1048576 --steps 200 --warmup 20
bench_abp head late --sizes 1048576 --steps 100 --warmup 3000
sweep_abp 1
sweep_abp 2
echo done t=$SECONDS >> $I; pack
