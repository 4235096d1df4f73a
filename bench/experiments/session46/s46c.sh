#!/bin/bash
# Session 46, call 3: delaunay plugin variant L (branch lawsonlocal46: Lawson's tail kernel at up
# to 1 024 particles works on copies of the topology, positions, stamps and lists in shared memory)
# against main 4f74f74's bundle: the Delaunay stages' CUDA tests and bits checks, then bench-abp at
# 256 to 16 384, three interleaved rounds.
#   bash bench/experiments/session46/s46c.sh gpu-carry/b46a.tar.xz    carry: gpu-carry (b46a, vL)
source tools/gpu/call_lib.sh s46c "$1"
declare -A D=([main]=$B [L]=$(variant L gpu-carry/vL.tar.xz))
delaunay_tests L
ROUNDS=3 rounds "main L" --sizes 256,512,1024,2048,16384 --steps 400 --warmup 20
echo done t=$SECONDS >> $I; pack
