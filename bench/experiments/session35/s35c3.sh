#!/bin/bash
# Session 35, call 3 (one H200): main e7c3e37, the session's code (plugin loading and messages,
# observers' .partial CSVs at checkpoints, failed-run hints, the HDF5 handle, set-up messages,
# tools/render and tools/convert; host code and Python only). The whole CUDA suite, then bench-abp
# at three sizes: session 34's call-3 script under this call's name.
#   bash bench/experiments/session35/s35c3.sh gpu-carry/BUNDLE.tar.gz   carry: the bundle
bash "$(dirname "$0")/../session34/s34c3.sh" "$1" s35c3
