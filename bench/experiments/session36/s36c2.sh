#!/bin/bash
# Session 36, call 2 (nvidia-h200): main 62cfbed, the session's code (call 1's fixes, then the
# input messages, sweep folders and --help, --resume taking the run's --set arguments, observe.gr's
# mixture pressure, pipeline bench's JSON, render and convert). The whole CUDA suite; bench-abp
# at 2^10, 2^14, 2^20 once, to see that nothing on the step's path moved (no kernel changed).
#   bash bench/experiments/session36/s36c2.sh gpu-carry/BUNDLE.tar.gz [NAME]   carry: the bundle
source tools/gpu/call_lib.sh "${2:-s36c2}" "$1"
suite "$B" 200
step suite 0
declare -A D=([main]=$B)
bench_abp main sizes --sizes 1024,16384,1048576
echo done t=$SECONDS >> $I; pack
