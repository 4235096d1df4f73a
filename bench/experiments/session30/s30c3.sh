#!/bin/bash
# Session 30, call 3: blk30 at a6e1d0b-ish (the cluster's tail in block 0's shared memory for a run
# alone of up to ~2 900 particles without walls): the correction's six CUDA test executables on its
# bundle, then bench-abp 200 steps after 20 at 2^10 / 2^11 / 2^12 against main's plugin (8649246)
# and the variant t512 (the cluster's tail from an iteration that moved at most 512, not 256),
# shadowed into the same bundle, three interleaved rounds (2^12 takes no shared tail: the control).
#   bash bench/experiments/session30/s30c3.sh gpu-carry/b30b.tar.gz    carry: the bundle, v30main.tgz, v30t512.tgz
source tools/gpu/call_lib.sh c3 "$1"
tar -xzf gpu-carry/v30main.tgz -C /tmp
tar -xzf gpu-carry/v30t512.tgz -C /tmp
declare -A D=([hyb]=$B [main]=$(shadow main /tmp/v30main) [t512]=$(shadow t512 /tmp/v30t512))
TEST_TIMEOUT=240 correction_tests hyb
for r in 1 2 3; do
  for v in main hyb t512; do bench_abp $v small --sizes 1024,2048,4096 --steps 200 --warmup 20; done
done
echo done t=$SECONDS >> $I; pack
