#!/bin/bash
# Session 25, call 4 (one H200, bundle b25a + HEAD's overlap_correct plugin, kClusterMaxN 8192):
# the cluster of 8 blocks (kSharedClusterBlocks, a sweep's) for every n <= 8192 against the
# cluster of 16: fewer blocks at each cluster barrier, fewer SMs. Its CPU == CUDA tests, then
# bench-abp 200 steps after 20, interleaved, three rounds.
#   carry: gpu-carry/b25a.tar.gz gpu-carry/v25c8.tgz
source tools/gpu/call_lib.sh c4 "$1"
tar -xzf gpu-carry/v25c8.tgz -C gpu-carry
declare -A D=([head]=$(shadow head gpu-carry/v25head) [c8]=$(shadow c8 gpu-carry/v25c8))
tests ${D[c8]} $O/tests-c8.txt test_overlap_correct_cpu_cuda test_overlap_correct; step tests-c8 0
b() { local v=$1 tag=$2; shift 2
  timeout 90 ${D[$v]}/bin/pipeline bench ${D[$v]}/pipelines/bench-abp.yaml --device cuda "$@" 2>&1 |
    grep -E "^[0-9]|overlap_correct/iter" | sed "s/^/$v $tag: /" >> $O/ab.txt; step $v-$tag $?; }
for v in head c8 c8 head head c8; do b $v small --sizes 1024,2048,4096,8192 --steps 200 --warmup 20; done
echo done t=$SECONDS >> $I; pack
