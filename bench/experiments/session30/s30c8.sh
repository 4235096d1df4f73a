#!/bin/bash
# Session 30, call 8: branch next30 (the shared tail's gathers write the moved positions to a
# second array, next, which the check reads while the apply copies them to pos: one barrier an
# iteration fewer, and no disp list), its plugin shadowed into b30e's bundle (whose tests include
# session 30's sizes): the correction's six test executables, then bench-abp 200 steps after 20
# at 2^10 / 2^11 / 2^12 against wt (c8241d9, blk30's head), three interleaved rounds.
#   bash bench/experiments/session30/s30c8.sh gpu-carry/b30e.tar.gz    carry: the bundle, v30wt/v30nxt.tgz
source tools/gpu/call_lib.sh c8 "$1"
for v in v30wt v30nxt; do tar -xzf gpu-carry/$v.tgz -C /tmp; done
declare -A D=([wt]=$(shadow wt /tmp/v30wt) [nxt]=$(shadow nxt /tmp/v30nxt))
TEST_TIMEOUT=240 correction_tests nxt
for r in 1 2 3; do
  for v in wt nxt; do bench_abp $v small --sizes 1024,2048,4096 --steps 200 --warmup 20; done
done
echo done t=$SECONDS >> $I; pack
