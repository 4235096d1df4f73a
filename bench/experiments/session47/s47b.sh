#!/bin/bash
# Session 47, call 2: the one-block dense correction's warp tail (branch wtail47: once an
# iteration touched at most kWarpTailMax particles, warp 0 alone runs the next iterations on the
# touched particles' edges) against main 213891e's plugin: the correction's six CUDA test
# executables and its error cases on the variant (w32), then bench-abp at 256 and 1 024 particles
# (three interleaved rounds of 400 steps) for main, w32 and w64 (kWarpTailMax 64).
#   bash bench/experiments/session47/s47b.sh gpu-carry/b47.tar.xz    carry: gpu-carry (b47, vw32, vw64)
source tools/gpu/call_lib.sh s47b "$1"
declare -A D=([main]=$B)
D[w32]=$(variant w32 gpu-carry/vw32.tar.xz)
D[w64]=$(variant w64 gpu-carry/vw64.tar.xz)
correction_tests w32
errors_test w32
ROUNDS=3 rounds "main w32 w64" --sizes 256,1024 --steps 400 --warmup 20
echo done t=$SECONDS >> $I; pack
