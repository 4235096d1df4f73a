#!/bin/bash
# Session 36, call 4 (nvidia-h200): main 91cecae, call 3's code and a host-only fix to --resume
# (a file valid only with the checkpoint's recorded --set arguments). Call 2's script under its
# own name: the whole CUDA suite, bench-abp at 2^10, 2^14, 2^20 once.
#   bash bench/experiments/session36/s36c4.sh gpu-carry/BUNDLE.tar.gz [NAME]   carry: the bundle
exec bash bench/experiments/session36/s36c2.sh "$1" "${2:-s36c4}"
