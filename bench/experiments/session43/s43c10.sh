#!/bin/bash
# Session 43, call 10: branch vedge43 (a flip reads its two vertex edges before its stores, not
# behind them) against main 38e13f2's bundle (b43b: the packed stores already): call 7's steps
# with its delaunay plugin (gpu-carry/vl.tar.xz).
#   bash bench/experiments/session43/s43c10.sh gpu-carry/b43b.tar.xz    carry: gpu-carry
bash "$(dirname "$0")/s43c7.sh" "$1" gpu-carry/vl.tar.xz "${2:-s43c10}"
