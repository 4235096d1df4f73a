#!/bin/bash
# Session 45, call 2: main 41cd655 (mesh.h's alignment checks as Mesh::he_vectors / vector_records;
# dense_block.cuh's shared arrays s_launch and s_bad, its cluster rank by cooperative groups): the
# whole CUDA suite; bench-abp at 1 024 and 16 384 against 9db0cd0's overlap_correct and delaunay
# plugins (variant old, in a shadow bundle), three interleaved rounds of 400 steps after 20; CUPTI
# timelines of the step at 2^10, 2^14 and 2^20 (issue 20's timeline, on the session's code).
#   bash bench/experiments/session45/s45c2.sh gpu-carry/b45n.tar.xz    carry: gpu-carry (b45n, vold)
source tools/gpu/call_lib.sh s45c2 "$1"
declare -A D=([main]=$B [old]=$(variant old gpu-carry/vold.tar.xz))
suite "$B" 280
step suite 0
ROUNDS=3 rounds "main old" --sizes 1024,16384 --steps 400 --warmup 20
timelines 1024 16384 1048576
echo done t=$SECONDS >> $I; pack
