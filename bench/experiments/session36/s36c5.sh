#!/bin/bash
# Session 36, call 5 (nvidia-h200): the read-through's commits (the repeated-mover check moved
# into StepGraph, test_checkpoint split in two, names), host and tests only. Call 2's script
# under its own name: the whole CUDA suite, bench-abp at 2^10, 2^14, 2^20 once.
#   bash bench/experiments/session36/s36c5.sh gpu-carry/BUNDLE.tar.gz [NAME]   carry: the bundle
exec bash bench/experiments/session36/s36c2.sh "$1" "${2:-s36c5}"
