#!/bin/bash
# Session 36, call 1 (nvidia-h200): main 5b633fb, after the session's host-only fixes (signals
# from set-up on, a second SIGINT stops at once; sweep folders, locks and extension; the repeated
# mover warning). The whole CUDA suite; then bench-abp at 2^10, 2^14, 2^20 in double (the
# issue's rows, as shipped) and in float (--set run.precision=float: is precision a lever at
# small N now that the correction's tail waits on its pair math? For users, not a row), three
# interleaved rounds; and 2^20 after 3 000 steps.
#   bash bench/experiments/session36/s36c1.sh gpu-carry/BUNDLE.tar.gz [NAME]   carry: the bundle
source tools/gpu/call_lib.sh "${2:-s36c1}" "$1"
suite "$B" 200
step suite 0
declare -A D=([main]=$B)
for round in 1 2 3; do
  bench_abp main "double-r$round" --sizes 1024,16384,1048576
  bench_abp main "float-r$round" --sizes 1024,16384,1048576 --set run.precision=float
done
BENCH_TIMEOUT=150 bench_abp main late --sizes 1048576 --warmup 3000 --steps 100
echo done t=$SECONDS >> $I; pack
