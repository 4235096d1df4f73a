#!/bin/bash
# Session 28, call 5: call 4's it0g28 A/B again without HOOMD-blue compiling beside it, and
# kGroupBelow = Threads / 4 (gb128: lane groups up to 128 particles a block, two passes of
# groups, where the grid's tiles are 128 now), against main (bundle b28f of 5da40b9), bench-abp
# 200 steps after 20 at 2^10..2^16, three interleaved rounds; gb128's correction tests first.
#   bash bench/experiments/session28/s28c5.sh gpu-carry/b28f.tar.gz   carry: b28f, v28it0, v28gb128
source tools/gpu/call_lib.sh c5 "$1"
for v in v28it0 v28gb128; do tar -xzf gpu-carry/$v.tgz -C /tmp; done
declare -A D=([main]=$B [it0]=$(shadow it0 /tmp/v28it0) [gb128]=$(shadow gb128 /tmp/v28gb128))
correction_tests gb128
for v in main it0 gb128 gb128 it0 main main gb128 it0; do
  bench_abp $v small --sizes 1024,2048,4096,8192,16384,65536 --steps 200 --warmup 20
done
echo done t=$SECONDS >> $I; pack
