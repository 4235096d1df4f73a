#!/bin/bash
# Session 42, call 7: branch dense-split42 (the dense cluster waits for the barrier after the moves
# only after the next reach test of the edges a block holds both ends of) against main 75de0de's
# plugin, interleaved; then the correction's CUDA tests and its error cases: call 6's steps.
#   bash bench/experiments/session42/s42c7.sh gpu-carry/b42f.tar.xz gpu-carry/main.tar.xz   carry: gpu-carry
bash "$(dirname "$0")/s42c6.sh" "$1" "$2" "${3:-s42c7}"
