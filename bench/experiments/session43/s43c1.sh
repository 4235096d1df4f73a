#!/bin/bash
# Session 43, call 1: main 94fa9b3 (review42-closed-gate merged: report_closed_gate and in_block in
# overlap_correct's kernels, never GPU-run before): the whole CUDA suite, then CUPTI timelines of
# bench-abp at 2^10, 2^14 and 2^20 (session 31's call 1), the untraced bench beside them.
#   bash bench/experiments/session43/s43c1.sh gpu-carry/b43a.tar.xz    carry: gpu-carry
source tools/gpu/call_lib.sh "${2:-s43c1}" "$1"
declare -A D=([main]=$B)
suite "$B" 280
step suite 0
bench_abp main rows --sizes 1024,16384 --steps 200 --warmup 20
bench_abp main big --sizes 1048576 --steps 100 --warmup 20
for n in 1024 16384 1048576; do
  st=200; [[ $n == 1048576 ]] && st=60
  CUDA_INJECTION64_PATH=$B/lib/libflipflow_gpu_trace.so FLIPFLOW_GPU_TRACE=/tmp/trace-$n.csv timeout 100 \
    $B/bin/pipeline bench $B/pipelines/bench-abp.yaml --device cuda --sizes $n --steps $st --warmup 20 > $O/trace-run-$n.txt 2>&1
  python3 tools/gpu_trace/summarize.py /tmp/trace-$n.csv --skip 25 --count $((st - 10)) > $O/trace-$n-summary.txt 2>&1
  python3 tools/gpu_trace/summarize.py /tmp/trace-$n.csv --skip 25 --count $((st - 10)) --group 2 > $O/trace-$n-group2.txt 2>&1
  xz -c /tmp/trace-$n.csv > $O/trace-$n.csv.xz
  step trace-$n $?
done
echo done t=$SECONDS >> $I; pack
