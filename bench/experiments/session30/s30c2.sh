#!/bin/bash
# Session 30, call 2: where the one-block kernel's time goes. The plugin of blk30 with
# overlap-clocks-block-and-cluster.patch (block 0's thread 0 prints clock64 per phase of each
# iteration of correction launches 150-152; FF_NO_BLOCK=1 keeps the cluster), in b30's bundle:
# bench-abp at 2^10 and 2^11 in one block and in the cluster of 16.
#   bash bench/experiments/session30/s30c2.sh gpu-carry/b30.tar.gz     carry: the bundle, v30clk.tgz
source tools/gpu/call_lib.sh c2 "$1"
tar -xzf gpu-carry/v30clk.tgz -C /tmp
C=$(shadow clk /tmp/v30clk)
for n in 1024 2048; do
  timeout 60 $C/bin/pipeline bench $C/pipelines/bench-abp.yaml --device cuda --sizes $n --steps 10 --warmup 160 > $O/block-$n.txt 2>&1
  step block-$n $?
  FF_NO_BLOCK=1 timeout 60 $C/bin/pipeline bench $C/pipelines/bench-abp.yaml --device cuda --sizes $n --steps 10 --warmup 160 > $O/cluster-$n.txt 2>&1
  step cluster-$n $?
done
echo done t=$SECONDS >> $I; pack
