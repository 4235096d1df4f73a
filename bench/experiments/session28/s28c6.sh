#!/bin/bash
# Session 28, call 6: lane groups up to 128 particles a block (gb128, kGroupBelow = Threads / 4)
# against the same for team iterations only (gbt: the tail keeps 64) and main (bundle b28f of
# 5da40b9), bench-abp 200 steps after 20 at 2^10..2^16, three interleaved rounds; gbt's tests first.
#   bash bench/experiments/session28/s28c6.sh gpu-carry/b28f.tar.gz   carry: b28f, v28gb128, v28gbt
source tools/gpu/call_lib.sh c6 "$1"
for v in v28gb128 v28gbt; do tar -xzf gpu-carry/$v.tgz -C /tmp; done
declare -A D=([main]=$B [gb128]=$(shadow gb128 /tmp/v28gb128) [gbt]=$(shadow gbt /tmp/v28gbt))
correction_tests gbt
for v in gbt gb128 main main gbt gb128 gb128 main gbt; do
  bench_abp $v small --sizes 1024,2048,4096,8192,16384,65536 --steps 200 --warmup 20
done
echo done t=$SECONDS >> $I; pack
