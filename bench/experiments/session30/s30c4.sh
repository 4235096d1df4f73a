#!/bin/bash
# Session 30, call 4: blk30 at 668de20 (the shared-memory tail as a kernel of its own, so that the
# sizes without it run main's kernels): the correction's six CUDA test executables, then bench-abp
# 200 steps after 20 at 2^10 / 2^11 / 2^12 / 2^13 against main's plugin (8649246) in the same
# bundle, three interleaved rounds (2^12 and 2^13 take no shared tail: the controls).
#   bash bench/experiments/session30/s30c4.sh gpu-carry/b30c.tar.gz    carry: the bundle, v30main.tgz
source tools/gpu/call_lib.sh c4 "$1"
tar -xzf gpu-carry/v30main.tgz -C /tmp
declare -A D=([hyb]=$B [main]=$(shadow main /tmp/v30main))
TEST_TIMEOUT=240 correction_tests hyb
for r in 1 2 3; do
  for v in main hyb; do bench_abp $v small --sizes 1024,2048,4096,8192 --steps 200 --warmup 20; done
done
echo done t=$SECONDS >> $I; pack
