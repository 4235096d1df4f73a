#!/bin/bash
# Session 25, call 3 (one H200, bundle b25a): two one-constant variants of overlap_correct, A/B
# against main's plugin: c16 (kClusterMaxN 16384: the cluster of 16 x 512 also at 2^13-2^14,
# where the grid ran; session 13 had it 6 % slower at 2^14, before the lists, the tail and PDL)
# and f8 (kInFlight 8: a gather's 8 listed positions loaded at once instead of two rounds of 4).
# Their CPU == CUDA tests, then bench-abp 200 steps after 20, interleaved, three rounds.
#   carry: gpu-carry/b25a.tar.gz gpu-carry/v25ab.tgz
source tools/gpu/call_lib.sh c3 "$1"
tar -xzf gpu-carry/v25ab.tgz -C gpu-carry
declare -A D=([main]=$B [c16]=$(shadow c16 gpu-carry/v25c16) [f8]=$(shadow f8 gpu-carry/v25f8))
for v in c16 f8; do tests ${D[$v]} $O/tests-$v.txt test_overlap_correct_cpu_cuda test_overlap_correct; step tests-$v 0; done
b() { local v=$1 tag=$2; shift 2
  timeout 90 ${D[$v]}/bin/pipeline bench ${D[$v]}/pipelines/bench-abp.yaml --device cuda "$@" 2>&1 |
    grep -E "^[0-9]|overlap_correct/iter" | sed "s/^/$v $tag: /" >> $O/ab.txt; step $v-$tag $?; }
for v in main c16 f8 f8 c16 main main c16 f8; do b $v small --sizes 1024,4096,8192,16384,65536 --steps 200 --warmup 20; done
echo done t=$SECONDS >> $I; pack
