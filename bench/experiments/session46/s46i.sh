#!/bin/bash
# Session 46, call 9: branch namecache46 (State::field by a C string remembers the field by the
# name's address, checked against the field's name) against main ffe2a9d (fieldcache46 merged, its
# bundle b46b): the whole CUDA suite on the branch, bench-abp at 2^10 and 2^14 (three interleaved
# rounds, pass 1 and the host's own time), and host_profile at 2^10 on the branch.
#   bash bench/experiments/session46/s46i.sh gpu-carry/b46c.tar.xz    carry: gpu-carry (b46c, b46b)
source tools/gpu/call_lib.sh s46i "$1"
mkdir -p /tmp/bm && tar -xJf gpu-carry/b46b.tar.xz -C /tmp/bm
declare -A D=([main]=/tmp/bm/bundle [N]=$B)
suite "$B" 280
step suite 0
ROUNDS=3 rounds "main N" --sizes 1024,16384 --steps 400 --warmup 20
host_profile 1024
echo done t=$SECONDS >> $I; pack
