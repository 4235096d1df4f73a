#!/bin/bash
# Session 25, call 8 (one H200, bundle b25c: the grid in blocks of 512, tiles >= 512): tiles of
# >= 256 (t256: at 2^14 64 blocks of 512 on 64 SMs instead of 32 on 32; the same from 2^16 up),
# against main's plugin: its CPU == CUDA tests, then bench-abp 200 steps after 20 at 2^14 and
# 2^15, three interleaved rounds.
#   carry: gpu-carry/b25c.tar.gz gpu-carry/v25t256.tgz
source tools/gpu/call_lib.sh c8 "$1"
tar -xzf gpu-carry/v25t256.tgz -C gpu-carry
declare -A D=([main]=$B [t256]=$(shadow t256 gpu-carry/v25t256))
TEST_TIMEOUT=100 tests ${D[t256]} $O/tests-t256.txt test_overlap_correct_cpu_cuda test_overlap_correct; step tests 0
b() { local v=$1 tag=$2; shift 2
  timeout 60 ${D[$v]}/bin/pipeline bench ${D[$v]}/pipelines/bench-abp.yaml --device cuda "$@" 2>&1 |
    grep -E "^[0-9]|overlap_correct/iter" | sed "s/^/$v $tag: /" >> $O/ab.txt; step $v-$tag $?; }
for v in main t256 t256 main main t256; do b $v mid --sizes 16384,32768 --steps 200 --warmup 20; done
echo done t=$SECONDS >> $I; pack
