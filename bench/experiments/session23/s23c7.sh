#!/bin/bash
# Session 23, call 7 (one H200): overlap_correct's kTailMoved (block 0 alone once an iteration
# moves at most this many particles; 512 since session 21, tuned at 2^20 after 3000 steps) at 256,
# 1 024 and 2 048 against main's 512, in shadow bundles (branch tailmoved): bench-abp at 2^10,
# 2^12, 2^14 (two interleaved rounds) and 2^20 (one).
#   carry: gpu-carry/<bundle>.tar.gz gpu-carry/tm-variants.tgz (tm{256,1024,2048}/libflipflow_stage_overlap_correct.so)
source tools/gpu/call_lib.sh c7 "$1"
tar -xzf gpu-carry/tm-variants.tgz -C gpu-carry
declare -A D=([512]=$B)
for v in 256 1024 2048; do D[$v]=$(shadow tm$v gpu-carry/tm$v); done
b() { local v=$1 tag=$2; shift 2
  timeout 90 ${D[$v]}/bin/pipeline bench ${D[$v]}/pipelines/bench-abp.yaml --device cuda "$@" 2>&1 |
    grep -E "^[0-9]|overlap_correct/(iter|pairs)" | sed "s/^/tm$v $tag: /" >> $O/ab.txt; step tm$v-$tag $?; }
for v in 512 256 1024 2048 2048 1024 256 512; do b $v small --sizes 1024,4096,16384 --steps 300 --warmup 20; done
for v in 512 1024 2048 256; do b $v big --sizes 1048576 --steps 200 --warmup 20; done
echo done t=$SECONDS >> $I; pack
