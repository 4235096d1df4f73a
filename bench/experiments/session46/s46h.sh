#!/bin/bash
# Session 46, call 8: branch fieldcache46 (067c998: the scheduler's field lookups once a run,
# ensure_topology without the accesses vector, collect_metrics' names in one string) against main
# 4f74f74: the whole CUDA suite on the branch, bench-abp at 2^10, 2^14 and 2^20 (three interleaved
# rounds, pass 1 and the host's own time), and host_profile at 2^10 on the branch.
#   bash bench/experiments/session46/s46h.sh gpu-carry/b46b.tar.xz    carry: gpu-carry (b46b, b46a)
source tools/gpu/call_lib.sh s46h "$1"
mkdir -p /tmp/bm && tar -xJf gpu-carry/b46a.tar.xz -C /tmp/bm
declare -A D=([main]=/tmp/bm/bundle [F]=$B)
suite "$B" 280
step suite 0
ROUNDS=3 rounds "main F" --sizes 1024,16384,1048576 --steps 400 --warmup 20
host_profile 1024
echo done t=$SECONDS >> $I; pack
