#!/bin/bash
# Session 40, call 2 (nvidia-h200): the whole CUDA suite on the session's last code (observe.clusters'
# tests split, the lattice pieces and messages helpers, test_checkpoint's long-layout case,
# tools/render's size distribution, the core_to_core probe), then bench-abp's rows once more.
#   bash bench/experiments/session40/s40c2.sh gpu-carry/BUNDLE.tar.gz [NAME]   carry: the bundle
source tools/gpu/call_lib.sh "${2:-s40c2}" "$1"
suite "$B" 200
step suite 0
declare -A D=([main]=$B)
bench_abp main rows --sizes 1024,16384,1048576 --steps 200 --warmup 20
echo done t=$SECONDS >> $I; pack
