#!/bin/bash
# Session 31, call 11: main 185fd73 (the publish change and Lawson's cluster tail from 32 768):
# every CUDA test; bench-abp against the session's start (61a8ccb's delaunay plugin, v31start, the
# only plugin that changed) in the same bundle, three interleaved rounds at 2^10..2^18, 2^20 (200
# after 20, 100 after 3 000); the 64-run sweep; Carter side by side.
#   bash bench/experiments/session31/s31c11.sh gpu-carry/b31f.tar.gz   carry: the bundle, v31start, peers-bundle.tar.gz
source tools/gpu/call_lib.sh c11 "$1"
tar -xzf gpu-carry/v31start.tgz -C /tmp
declare -A D=([main]=$B [start]=$(shadow start /tmp/v31start))
suite $B 240
step suite 0
for r in 1 2 3; do
  for v in start main; do bench_abp $v r$r --sizes 1024,2048,4096,8192,16384,32768,65536,131072,262144 --steps 200 --warmup 20; done
done
for v in start main; do bench_abp $v big --sizes 1048576 --steps 200 --warmup 20; done
for v in main start; do bench_abp $v late --sizes 1048576 --steps 100 --warmup 3000; done
sweep_abp 1
mkdir -p /tmp/pb && tar -xzf gpu-carry/peers-bundle.tar.gz -C /tmp/pb
((SECONDS < 480)) && { timeout $((580 - SECONDS)) bash bench/carter_side_by_side.sh $B /tmp/pb/bundle $O/carter small > $O/carter-run.txt 2>&1; step carter $?; }
echo done t=$SECONDS >> $I; pack
