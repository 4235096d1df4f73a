#!/bin/bash
# Prepared in session 25 for branch fused25, not yet run: overlap_correct's check reads the
# iteration's new positions from a second array (next, written by the gathers) while the apply
# writes pos, so a team iteration has two barriers instead of three (grid or cluster; the tail
# saves a __syncthreads). Not on the wide path (2^17 and up). Build the branch's plugin, then
# with a bundle of main:   carry: BUNDLE.tar.gz and a .tgz of the plugin folder (v26fused)
#   bash bench/experiments/session25/next-fused-check.sh BUNDLE.tar.gz
source tools/gpu/call_lib.sh fused "$1"
tar -xzf gpu-carry/v26fused.tgz -C gpu-carry
declare -A D=([main]=$B [fused]=$(shadow fused gpu-carry/v26fused))
TEST_TIMEOUT=200 tests ${D[fused]} $O/tests-fused.txt test_overlap_correct_cpu_cuda test_overlap_correct \
  test_overlap_correct_walls test_overlap_correct_determinism test_cpu_cuda_bits test_device_decisions
step tests 0
b() { local v=$1 tag=$2; shift 2
  timeout 90 ${D[$v]}/bin/pipeline bench ${D[$v]}/pipelines/bench-abp.yaml --device cuda "$@" 2>&1 |
    grep -E "^[0-9]|overlap_correct/iter" | sed "s/^/$v $tag: /" >> $O/ab.txt; step $v-$tag $?; }
for v in main fused fused main main fused; do b $v small --sizes 1024,4096,8192,16384,65536 --steps 200 --warmup 20; done
echo done t=$SECONDS >> $I; pack
