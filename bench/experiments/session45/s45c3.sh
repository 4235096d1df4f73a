#!/bin/bash
# Session 45, call 3: is the host a ceiling for the small rows? Call 2's CUPTI timeline at 2^10
# had the GPU idle 7.3 us a step, waiting for launches (under CUPTI a launch call takes ~6 us).
# host_waits.c (LD_PRELOAD) times every launch and every wait of `pipeline bench`; host_waits.py
# prints the host's own time a step (the period minus its waits) over the back-to-back pass, at
# 256, 1 024 and 16 384 particles; then bench-abp without the shim at 64-1 024 particles.
#   bash bench/experiments/session45/s45c3.sh gpu-carry/b45n.tar.xz    carry: gpu-carry (b45n)
source tools/gpu/call_lib.sh s45c3 "$1"
declare -A D=([main]=$B)
# (these calls ran the same lines written out, from bench/experiments/session45; call_lib.sh's
# host_waits came after them)
host_waits 256 1024 16384
ROUNDS=2 rounds main --sizes 64,128,256,512,1024 --steps 400 --warmup 20
echo done t=$SECONDS >> $I; pack
