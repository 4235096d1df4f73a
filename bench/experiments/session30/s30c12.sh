#!/bin/bash
# Session 30, call 12: branch dtail30 (the shared tail in the cluster's distributed shared memory:
# each block keeps its tile's positions and lists, block 0 runs the tail reading them through
# mapa; for every cluster size, 2^13 included): its correction test executables, then bench-abp
# 200 steps after 20 at 2^10 - 2^13 against main (713c209's plugin), three interleaved rounds.
#   bash bench/experiments/session30/s30c12.sh gpu-carry/b30h.tar.gz    carry: the bundle, v30m2.tgz
source tools/gpu/call_lib.sh c12 "$1"
tar -xzf gpu-carry/v30m2.tgz -C /tmp
declare -A D=([dtail]=$B [main]=$(shadow main /tmp/v30m2))
TEST_TIMEOUT=240 correction_tests dtail
for r in 1 2 3; do
  for v in main dtail; do bench_abp $v small --sizes 1024,2048,4096,8192 --steps 200 --warmup 20; done
done
echo done t=$SECONDS >> $I; pack
