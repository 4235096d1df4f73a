#!/bin/bash
# Session 47, call 10: is the Carter row's step (bench-hd07, hard disks φ = 0.7, brownian D = 0.0125
# + Delaunay + correction) bound by the host? `pipeline bench` at 2^14, 2^16 and 2^18 on main's
# bundle with the host's own time a step and the stages' split (400 steps after 20).
#   bash bench/experiments/session47/s47h.sh gpu-carry/b47.tar.xz    carry: gpu-carry (b47)
source tools/gpu/call_lib.sh s47h "$1"
for n in 16384 65536 262144; do
  timeout 120 "$B/bin/pipeline" bench "$B/pipelines/bench-hd07.yaml" --device cuda --sizes $n --steps 400 --warmup 20 > "$O/hd07-$n.txt" 2>&1
  step hd07-$n $?
done
echo done t=$SECONDS >> $I; pack
