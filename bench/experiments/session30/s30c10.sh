#!/bin/bash
# Session 30, call 10: the shared tail's lane groups for more particles (on main 2e896b5: g256 up to
# 256 a block, two passes more; gall always, whatever the count), against main's bundle, bench-abp
# 200 steps after 20 at 2^10 / 2^11 / 2^12, three interleaved rounds; then both variants' correction
# test executables.
#   bash bench/experiments/session30/s30c10.sh gpu-carry/b30f.tar.gz    carry: the bundle, v30g256/v30gall.tgz
source tools/gpu/call_lib.sh c10 "$1"
for v in v30g256 v30gall; do tar -xzf gpu-carry/$v.tgz -C /tmp; done
declare -A D=([head]=$B [g256]=$(shadow g256 /tmp/v30g256) [gall]=$(shadow gall /tmp/v30gall))
for r in 1 2 3; do
  for v in head g256 gall; do bench_abp $v small --sizes 1024,2048,4096 --steps 200 --warmup 20; done
done
TEST_TIMEOUT=240 correction_tests g256 gall
echo done t=$SECONDS >> $I; pack
