#!/bin/bash
# Session 47, call 5: skip47's reach-test skip with a thread's edges consecutive in the one block
# (3·tid + r: a warp holds the edges of ~32 neighbouring particles, so the few touched late in a
# launch leave most warps out) against main 213891e's plugin: the correction's six CUDA test
# executables and its error cases, then bench-abp at 256, 512, 1 024 and 4 096 (a cluster,
# unchanged), three interleaved rounds of 400 steps.
#   bash bench/experiments/session47/s47e.sh gpu-carry/b47.tar.xz    carry: gpu-carry (b47, vskipc)
source tools/gpu/call_lib.sh s47e "$1"
declare -A D=([main]=$B)
D[skipc]=$(variant skipc gpu-carry/vskipc.tar.xz)
correction_tests skipc
errors_test skipc
ROUNDS=3 rounds "main skipc" --sizes 256,512,1024,4096 --steps 400 --warmup 20
echo done t=$SECONDS >> $I; pack
