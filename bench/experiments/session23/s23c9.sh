#!/bin/bash
# Session 23, call 9 (one H200): branch pdl (programmatic dependent launches: detect's marking,
# Lawson's tail kernel and the correction's cluster kernel may be scheduled before the kernel
# before them ends, and wait for it on the device) against main, in a shadow bundle: the CUDA
# tests of the three stages, bench-abp at 2^10, 2^12, 2^14 (three interleaved rounds) and 2^20.
#   carry: gpu-carry/<bundle>.tar.gz gpu-carry/pdl.tgz
source tools/gpu/call_lib.sh c9 "$1"
tar -xzf gpu-carry/pdl.tgz -C gpu-carry
V=$(shadow pdl gpu-carry/pdl)
tests $V $O/tests-pdl.txt test_cpu_cuda_bits test_delaunay_detect_inversion test_delaunay_lawson test_overlap_correct; step tests 0
declare -A D=([main]=$B [pdl]=$V)
b() { local v=$1 tag=$2; shift 2
  timeout 90 ${D[$v]}/bin/pipeline bench ${D[$v]}/pipelines/bench-abp.yaml --device cuda "$@" 2>&1 |
    grep -E "^[0-9]|overlap_correct/iter" | sed "s/^/$v $tag: /" >> $O/ab.txt; step $v-$tag $?; }
for v in main pdl pdl main main pdl; do b $v small --sizes 1024,4096,16384 --steps 300 --warmup 20; done
for v in main pdl; do b $v big --sizes 1048576 --steps 200 --warmup 20; done
CUDA_INJECTION64_PATH=$B/lib/libflipflow_gpu_trace.so FLIPFLOW_GPU_TRACE=$O/trace-pdl-1024.csv timeout 30 $V/bin/pipeline bench $V/pipelines/bench-abp.yaml --device cuda --sizes 1024 --steps 30 --warmup 20 > $O/trace-pdl-1024.txt 2>&1; step trace $?
echo done t=$SECONDS >> $I; pack
