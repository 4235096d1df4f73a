#!/bin/bash
# Session 34, call 5 (nvidia-h200-x2): main 3e1fb4d, the session's last code (after call 4: the review's fixes:
# observe.h5md's stage state, a continuation's folder check; host code only). The same as call 3's script (s34c3.sh).
#   bash bench/experiments/session34/s34c5.sh gpu-carry/BUNDLE.tar.gz   carry: the bundle
bash "$(dirname "$0")/s34c3.sh" "$1" s34c5
