#!/bin/bash
# Session 45, call 7: main with the host's own time in `pipeline bench` (core/backend/host_wait.h):
# the whole CUDA suite; bench-abp at 2^10, 2^14 and 2^20 (its new line); the preload shim at 2^10
# beside it (tools/gpu/host_waits.c: the same quantity measured from outside).
#   bash bench/experiments/session45/s45c7.sh gpu-carry/b45p.tar.xz    carry: gpu-carry (b45p)
source tools/gpu/call_lib.sh s45c7 "$1"
declare -A D=([main]=$B)
suite "$B" 280
step suite 0
timeout 120 "$B/bin/pipeline" bench "$B/pipelines/bench-abp.yaml" --device cuda --sizes 1024,16384,1048576 \
  --steps 200 --warmup 20 --results /tmp/r > $O/bench-host.txt 2>&1
step bench-host $?
host_waits 1024
echo done t=$SECONDS >> $I; pack
