#!/bin/bash
# Session 41, call 6 (nvidia-h200): ncu of the dense kernel after call 5 (warp-slot sums), with
# the densest stall sampling, three launches 120 steps in, at 1 024 and 2 048 particles: stall
# reasons, instruction mix, per-instruction samples; and its SASS. Call 2's script with more
# launches and sampling (it ran as the same commands written out; the ncu option was found by
# `ncu --help` in the call).
#   bash bench/experiments/session41/s41c6.sh gpu-carry/BUNDLE.tar.gz   carry: gpu-carry
NCU_LAUNCHES=3 NCU_SAMPLING="--warp-sampling-interval 0" SIZES="1024 2048" \
  bash "$(dirname "$0")/s41c2.sh" "$1" "${2:-s41c6}"
