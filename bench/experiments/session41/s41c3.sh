#!/bin/bash
# Session 41, call 3 (nvidia-h200): the dense path, second form (listed edges, pushes linked into
# each end's list by 32-bit exchanges instead of 64-bit shared atomics), against main 1a62138's
# plugin, the cluster team and its shared tail. The correction's CUDA tests and the error cases,
# then bench-abp at 2^10-2^12 (2^12: above the path's 2 048, the same code in both), three rounds:
# call 1's script at these sizes (it ran as a copy of it).
#   bash bench/experiments/session41/s41c3.sh gpu-carry/BUNDLE.tar.gz gpu-carry/OLDPLUGIN.tar.gz   carry: gpu-carry
SIZES=1024,2048,4096 bash "$(dirname "$0")/s41c1.sh" "$1" "$2" "${3:-s41c3}"
