#!/bin/bash
# Session 35, call 5 (one H200): main 9ca1ac0, the session's last code (after call 3: the
# observables-only H5MD file, tools/render's 3D views and labels, tests, docs; host code and Python).
# The whole CUDA suite and bench-abp at three sizes: session 34's call-3 script under this name.
#   bash bench/experiments/session35/s35c5.sh gpu-carry/BUNDLE.tar.gz   carry: the bundle
bash "$(dirname "$0")/../session34/s34c3.sh" "$1" s35c5
