#!/bin/bash
# Session 39, call 3 (nvidia-h200): the session's last code (trap.harmonic's velocity and types,
# observe.mean, NaN for fields not computed yet in the initial frame, the validate warning): the
# whole CUDA suite and bench-abp at 2^10, 2^14, 2^20 once, as call 1 (session 36's call-2 script).
#   bash bench/experiments/session39/s39c3.sh gpu-carry/BUNDLE.tar.gz [NAME]   carry: the bundle
exec bash bench/experiments/session36/s36c2.sh "$1" "${2:-s39c3}"
