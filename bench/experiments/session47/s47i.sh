#!/bin/bash
# Session 47, call 11: the GPU's own time a step against the step, where the host's own time is
# close to it (call 10: bench-hd07 2^14 37.3 µs a step, the host's own 21.9): CUPTI timelines
# (tools/gpu_trace) of bench-hd07 at 2^14 and 2^16 and bench-abp at 2^10 and 2^14, 200 steps after
# 20, summarize.py's typical step (busy, idle, each kernel's extension).
#   bash bench/experiments/session47/s47i.sh gpu-carry/b47.tar.xz    carry: gpu-carry (b47)
source tools/gpu/call_lib.sh s47i "$1"
trace() {  # PIPELINE N MARKER
  local f=$1 n=$2 m=$3 t=/tmp/trace-$1-$2.csv
  CUDA_INJECTION64_PATH=$B/lib/libflipflow_gpu_trace.so FLIPFLOW_GPU_TRACE=$t timeout 100 \
    "$B/bin/pipeline" bench "$B/pipelines/$f.yaml" --device cuda --sizes "$n" --steps 200 --warmup 20 \
    > "$O/trace-run-$f-$n.txt" 2>&1
  python3 tools/gpu_trace/summarize.py $t --step-marker "$m" --skip 25 --count 190 > "$O/trace-$f-$n-summary.txt" 2>&1
  xz -c $t > "$O/trace-$f-$n.csv.xz"
  step trace-$f-$n $?
}
trace bench-hd07 16384 overdamped_kernel
trace bench-hd07 65536 overdamped_kernel
trace bench-abp 1024 abp
trace bench-abp 16384 abp
echo done t=$SECONDS >> $I; pack
