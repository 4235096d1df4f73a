#!/bin/bash
# Session 23, call 6 (one H200): CUPTI traces for the record: bench-abp at 2^20 (deciding on the
# host: more candidates than a gated launch takes) and at 2^14 deciding on the host, beside call
# 1's 2^14 deciding on the device.
source tools/gpu/call_lib.sh c6 "$1"
P=$B/pipelines
tr() { local n=$1 v=$2
  FLIPFLOW_DEVICE_DECISIONS=$v CUDA_INJECTION64_PATH=$B/lib/libflipflow_gpu_trace.so FLIPFLOW_GPU_TRACE=$O/trace-$n-dd$v.csv \
    timeout 60 $B/bin/pipeline bench $P/bench-abp.yaml --device cuda --sizes $n --steps 30 --warmup 20 > $O/trace-$n-dd$v.txt 2>&1
  step trace-$n-dd$v $?; }
tr 1048576 1; tr 16384 0; tr 1024 0
echo done t=$SECONDS >> $I; pack
