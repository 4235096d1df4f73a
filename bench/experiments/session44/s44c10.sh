#!/bin/bash
# Session 44, call 10: delaunay plugin variant K (branch claims44: an applied flip's claims made
# before its flip on the device, their answers used after it) against main 3cd3b0e's bundle: the
# Delaunay, bits, rollback, graph-capture and device-decision CUDA test executables
# (`delaunay_tests`), then bench-abp at 2^10, 2^14, 2^16 and 2^20, five interleaved rounds.
#   bash bench/experiments/session44/s44c10.sh gpu-carry/b44m.tar.xz    carry: gpu-carry (b44m, vK)
source tools/gpu/call_lib.sh s44c10 "$1"
declare -A D=([main]=$B [K]=$(variant K gpu-carry/vK.tar.xz))
delaunay_tests K
ROUNDS=5 rounds "main K" --sizes 1024,16384,65536,1048576 --steps 400 --warmup 20
echo done t=$SECONDS >> $I; pack
