#!/bin/bash
# Session 30, call 7: blk30 at ab051e8 (dsm: every block of the cluster copies its tile into block
# 0's shared memory when the tail starts), its correction test executables, then bench-abp 200
# steps after 20 at 2^10 / 2^11 / 2^12 / 2^13 against main (8649246), cmp (55b6fa7: block 0 copies
# everything, then copies every position back) and wt (c8241d9: moves written through, no copy
# back), shadowed into the same bundle, three interleaved rounds.
#   bash bench/experiments/session30/s30c7.sh gpu-carry/b30e.tar.gz    carry: the bundle, v30main/v30cmp/v30wt.tgz
source tools/gpu/call_lib.sh c7 "$1"
for v in v30main v30cmp v30wt; do tar -xzf gpu-carry/$v.tgz -C /tmp; done
declare -A D=([dsm]=$B [main]=$(shadow main /tmp/v30main) [cmp]=$(shadow cmp /tmp/v30cmp) [wt]=$(shadow wt /tmp/v30wt))
TEST_TIMEOUT=240 correction_tests dsm
for r in 1 2 3; do
  for v in main cmp wt dsm; do bench_abp $v small --sizes 1024,2048,4096,8192 --steps 200 --warmup 20; done
done
echo done t=$SECONDS >> $I; pack
