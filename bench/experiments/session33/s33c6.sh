#!/bin/bash
# Session 33, call 6: the whole CUDA suite on the session's last code (7dbb08f: f7f5f32's team
# order for branched steps, the h5md writer's wait on a failed write; after it only docs).
#   bash bench/experiments/session33/s33c6.sh gpu-carry/b33e.tar.gz   carry: b33e
source tools/gpu/call_lib.sh c6 "$1"
suite "$B" 200
step suite 0
echo done t=$SECONDS >> $I; pack
