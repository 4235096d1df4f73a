#!/bin/bash
# Session 39 (nvidia-h200): the session's code (the trap.harmonic plugin merged; host-side and
# stage code only, no change to the step's kernels). Session 36's call 2 under its own name: the
# whole CUDA suite, bench-abp at 2^10, 2^14, 2^20 once.
#   bash bench/experiments/session39/s39c1.sh gpu-carry/BUNDLE.tar.gz [NAME]   carry: the bundle
exec bash bench/experiments/session36/s36c2.sh "$1" "${2:-s39c1}"
