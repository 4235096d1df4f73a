#!/bin/bash
# Session 30, call 5: blk30 at 55b6fa7 (the shared-memory tail in 16-bit ids and one-bit marks, up
# to ~4 100 particles in double): the correction's six CUDA test executables, then bench-abp 200
# steps after 20 at 2^10 / 2^11 / 2^12 / 2^13 against main's plugin (8649246), hyb (90f12ff: the
# 32-bit layout, up to ~3 000) and t128 (55b6fa7 with the tail from an iteration that moved at most
# 128, not 256), shadowed into the same bundle, three interleaved rounds (2^13: the control).
#   bash bench/experiments/session30/s30c5.sh gpu-carry/b30d.tar.gz    carry: the bundle, v30main/v30hyb/v30t128.tgz
source tools/gpu/call_lib.sh c5 "$1"
for v in v30main v30hyb v30t128; do tar -xzf gpu-carry/$v.tgz -C /tmp; done
declare -A D=([compact]=$B [main]=$(shadow main /tmp/v30main) [hyb]=$(shadow hyb /tmp/v30hyb) [t128]=$(shadow t128 /tmp/v30t128))
TEST_TIMEOUT=240 correction_tests compact
for r in 1 2 3; do
  for v in main hyb compact t128; do bench_abp $v small --sizes 1024,2048,4096,8192 --steps 200 --warmup 20; done
done
echo done t=$SECONDS >> $I; pack
