#!/bin/bash
# Session 32, call 5: the whole CUDA suite on the session's last code (main, lawson_tail_pass, take_gather,
# gated grid rounds, comments after).
#   bash bench/experiments/session32/s32c5.sh gpu-carry/b32e.tar.gz   carry: b32e
source tools/gpu/call_lib.sh c5 "$1"
suite "$B" 150
step suite 0
echo done t=$SECONDS >> $I; pack
