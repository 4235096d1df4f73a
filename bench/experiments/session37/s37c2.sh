#!/bin/bash
# Session 37, call 2 (nvidia-h200): call 1's code with the out-of-tree SDK branch merged (the
# test-support headers installed, a compiled-in plugin path for tests built against an install,
# FLIPFLOW_PLUGIN_CUDA=OFF; host code, tests and docs). Session 36's call 2 under its own name:
# the whole CUDA suite, bench-abp at 2^10, 2^14, 2^20 once.
#   bash bench/experiments/session37/s37c2.sh gpu-carry/BUNDLE.tar.gz [NAME]   carry: the bundle
exec bash bench/experiments/session36/s36c2.sh "$1" "${2:-s37c2}"
