#!/bin/bash
# Session 48, call 6: the whole CUDA suite on main 06c9f3b (pdlwide48 merged: the wide kernels and
# Lawson's grid rounds launched programmatically), then bench-abp at 2^10, 2^14 and 2^20, 2^20
# after 3 000 steps, and Carter side by side (bench-hd07 against Carter et al.'s program).
#   bash bench/experiments/session48/s48c6.sh gpu-carry/b48m.tar.xz   carry: gpu-carry (the bundle,
#   peers-bundle.tar.gz = ../shared/peers-gpu/bundle)
source tools/gpu/call_lib.sh s48c6 "$1"
declare -A D=([main]=$B)
suite "$B" 250
step suite 0
bench_abp main rows --sizes 1024,16384,1048576 --steps 200 --warmup 20
bench_abp main late --sizes 1048576 --steps 100 --warmup 3000
mkdir -p /tmp/pb && tar -xzf gpu-carry/peers-bundle.tar.gz -C /tmp/pb
timeout 90 bash bench/carter_side_by_side.sh "$B" /tmp/pb/bundle "$O/carter" small > "$O/carter-run.txt" 2>&1
step carter $?
echo done t=$SECONDS >> $I; pack
