#!/bin/bash
# Session 41, call 10 (nvidia-h200): the whole CUDA suite on the session's code (overlap_correct's
# dense block for runs alone up to 2 048 particles), then bench-abp's rows (2^10, 2^14, 2^20) and
# the dense block against main 1a62138's plugin below 2^10 (256, 512) and at 2^10, two rounds.
#   bash bench/experiments/session41/s41c10.sh gpu-carry/BUNDLE.tar.gz gpu-carry/OLDPLUGIN.tar.gz   carry: gpu-carry
source tools/gpu/call_lib.sh "${3:-s41c10}" "$1"
mkdir -p /tmp/oldp && tar -xzf "$2" -C /tmp/oldp
OLD=$(shadow old /tmp/oldp)
declare -A D=([main]=$B [old]=$OLD)
for r in 1 2; do
  for v in main old; do bench_abp $v r$r --sizes 256,512,1024 --steps 200 --warmup 20; done
done
bench_abp main rows --sizes 1024,16384,1048576 --steps 200 --warmup 20
suite "$B" 200
step suite 0
echo done t=$SECONDS >> $I; pack
