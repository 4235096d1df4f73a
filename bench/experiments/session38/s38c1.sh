#!/bin/bash
# Session 38 (nvidia-h200): the session's code (observe.h5md's frames_every and metrics written at
# the step they were reported, RunStats::metric_stamps, the observers' fixes; host code, tests and
# docs: no kernel changed). Session 36's call 2 under its own name: the whole CUDA suite, bench-abp
# at 2^10, 2^14, 2^20 once.
#   bash bench/experiments/session38/s38c1.sh gpu-carry/BUNDLE.tar.gz [NAME]   carry: the bundle
exec bash bench/experiments/session36/s36c2.sh "$1" "${2:-s38c1}"
