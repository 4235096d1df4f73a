#!/bin/bash
# Session 43, call 2: what one barrier costs in the dense cluster. Shadow plugins of overlap_correct
# built from main 94fa9b3 with one line added after the reach test's block barrier in the cluster
# path: x1 an extra cluster barrier, x2 an extra block barrier (same iterations, same bits);
# interleaved with main's bundle, three rounds (patch: session43/dense-extra-barrier.patch).
#   bash bench/experiments/session43/s43c2.sh gpu-carry/b43a.tar.xz    carry: gpu-carry
# (Its plugin unpacking, rounds and error cases are call_lib.sh's `variant`, `rounds` and
# `errors_test` now, which took over those lines.)
source tools/gpu/call_lib.sh "${2:-s43c2}" "$1"
declare -A D=([main]=$B [x1]=$(variant x1 gpu-carry/px1.tar.xz) [x2]=$(variant x2 gpu-carry/px2.tar.xz))
rounds "main x1 x2" --sizes 2048,4096,8192,16384 --steps 200 --warmup 20
echo done t=$SECONDS >> $I; pack
