#!/bin/bash
# Session 25, call 7 (one H200, bundle b25c: the grid in blocks of 512): the grid's tail threshold
# with the larger block, 1024 (t1024) and 2048 (t2048) particles moved instead of 512 (the
# cluster keeps 512; session 23 measured 1024 slower there), against main's plugin: CPU == CUDA
# tests, bench-abp 200 steps after 20 at 2^14 / 2^16 / 2^18 (two interleaved rounds), and 2^20
# 100 steps after 3000.
#   carry: gpu-carry/b25c.tar.gz gpu-carry/v25t.tgz
source tools/gpu/call_lib.sh c7 "$1"
tar -xzf gpu-carry/v25t.tgz -C gpu-carry
declare -A D=([main]=$B [t1024]=$(shadow t1024 gpu-carry/v25t1024) [t2048]=$(shadow t2048 gpu-carry/v25t2048))
for v in t1024 t2048; do TEST_TIMEOUT=120 tests ${D[$v]} $O/tests-$v.txt test_overlap_correct_cpu_cuda test_overlap_correct & done
wait; step tests 0
b() { local v=$1 tag=$2; shift 2
  timeout 90 ${D[$v]}/bin/pipeline bench ${D[$v]}/pipelines/bench-abp.yaml --device cuda "$@" 2>&1 |
    grep -E "^[0-9]|overlap_correct/iter" | sed "s/^/$v $tag: /" >> $O/ab.txt; step $v-$tag $?; }
for v in main t1024 t2048 t2048 t1024 main; do b $v mid --sizes 16384,65536,262144 --steps 200 --warmup 20; done
for v in t1024 main t2048; do b $v late --sizes 1048576 --steps 100 --warmup 3000; done
echo done t=$SECONDS >> $I; pack
