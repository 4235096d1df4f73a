#!/bin/bash
# Session 28, call 3: overlap_correct's team thresholds after the grid's tiles went to 128 (main
# cad780c, plugin v28main) against three one-constant variants of it:
#   g4k:   kClusterMaxN 4096 (2^13 on the grid: 64 blocks of 128);
#   g4k64: kClusterMaxN 4096 and kMinTile 64 (2^13 on 128 blocks of 64);
#   g1k64: kClusterMaxN 1024 and kMinTile 64 (2^11 on 32 blocks, 2^12 on 64, 2^13 on 128).
# The correction tests on CUDA for main, g4k64 and g1k64, then bench-abp 200 steps after 20 at
# 2^10..2^14, three interleaved rounds.
#   bash bench/experiments/session28/s28c3.sh gpu-carry/b28.tar.gz   carry: b28, v28main, v28g4k, v28g4k64, v28g1k64
source tools/gpu/call_lib.sh c3 "$1"
for v in v28main v28g4k v28g4k64 v28g1k64; do tar -xzf gpu-carry/$v.tgz -C /tmp; done
declare -A D=([main]=$(shadow main /tmp/v28main) [g4k]=$(shadow g4k /tmp/v28g4k) [g4k64]=$(shadow g4k64 /tmp/v28g4k64) [g1k64]=$(shadow g1k64 /tmp/v28g1k64))
correction_tests main g4k64 g1k64
for v in main g4k g4k64 g1k64 g1k64 g4k64 g4k main main g1k64 g4k g4k64; do
  bench_abp $v small --sizes 1024,2048,4096,8192,16384 --steps 200 --warmup 20
done
echo done t=$SECONDS >> $I; pack
