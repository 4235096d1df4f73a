#!/bin/bash
# Session 36, call 3 (nvidia-h200): main 8106e7f, the session's last code: call 2's, then the
# review's fixes (sweep lock, older sweep.txt, double Ctrl-C, multi-line --set on resume, the first
# signal reported) and the nested --set messages; host only. The whole CUDA suite; bench-abp at
# 2^10, 2^14, 2^20 once.
#   bash bench/experiments/session36/s36c3.sh gpu-carry/BUNDLE.tar.gz [NAME]   carry: the bundle
source tools/gpu/call_lib.sh "${2:-s36c3}" "$1"
suite "$B" 200
step suite 0
declare -A D=([main]=$B)
bench_abp main sizes --sizes 1024,16384,1048576
echo done t=$SECONDS >> $I; pack
