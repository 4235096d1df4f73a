#!/bin/bash
# Session 46, call 1: main with each stage's part of the host's own time in `pipeline bench`
# (StageSlot::host_seconds): the whole CUDA suite (the scheduler changed), then bench-abp at 2^10,
# 2^14 and 2^20.
#   bash bench/experiments/session46/s46a.sh gpu-carry/b46a.tar.xz    carry: gpu-carry (b46a)
source tools/gpu/call_lib.sh s46a "$1"
suite "$B" 280
step suite 0
timeout 120 "$B/bin/pipeline" bench "$B/pipelines/bench-abp.yaml" --device cuda --sizes 1024,16384,1048576 \
  --steps 200 --warmup 20 --results /tmp/r > $O/bench-host.txt 2>&1
step bench-host $?
cp /tmp/r/*.jsonl $O/
echo done t=$SECONDS >> $I; pack
