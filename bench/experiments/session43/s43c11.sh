#!/bin/bash
# Session 43, call 11: the whole CUDA suite on main a0cd9c2 (vedge43 merged: a flip's vertex
# edges read before its stores), and bench-abp at 2^10, 2^14 and 2^20 once.
#   bash bench/experiments/session43/s43c11.sh gpu-carry/b43c.tar.xz    carry: gpu-carry
source tools/gpu/call_lib.sh "${2:-s43c11}" "$1"
declare -A D=([main]=$B)
suite "$B" 280
step suite 0
bench_abp main rows --sizes 1024,16384,1048576 --steps 200 --warmup 20
echo done t=$SECONDS >> $I; pack
