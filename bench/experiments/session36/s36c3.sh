#!/bin/bash
# Session 36, call 3 (nvidia-h200): main 8106e7f, the session's last code: call 2's, then the
# review's fixes (sweep lock, older sweep.txt, double Ctrl-C, multi-line --set on resume, the first
# signal reported) and the nested --set messages; host only. Call 2's script under its own name:
# the whole CUDA suite, bench-abp at 2^10, 2^14, 2^20 once.
#   bash bench/experiments/session36/s36c3.sh gpu-carry/BUNDLE.tar.gz [NAME]   carry: the bundle
exec bash bench/experiments/session36/s36c2.sh "$1" "${2:-s36c3}"
