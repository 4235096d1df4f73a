#!/bin/bash
# Session 31, call 1: main 61a8ccb (code of 713c209): CUPTI timelines of bench-abp at 2^10, 2^14,
# 2^16 and 2^20 (the timed back-to-back pass), to see where a step's time goes now, and the
# untraced bench beside them.
#   bash bench/experiments/session31/s31c1.sh gpu-carry/b31a.tar.gz [NAME]    carry: the bundle
source tools/gpu/call_lib.sh "${2:-c1}" "$1"
declare -A D=([head]=$B)
bench_abp head small --sizes 1024,16384,65536 --steps 200 --warmup 20
bench_abp head big --sizes 1048576 --steps 100 --warmup 20
for n in 1024 16384 65536 1048576; do
  st=200; [[ $n == 1048576 ]] && st=60
  CUDA_INJECTION64_PATH=$B/lib/libflipflow_gpu_trace.so FLIPFLOW_GPU_TRACE=/tmp/trace-$n.csv timeout 120 \
    $B/bin/pipeline bench $B/pipelines/bench-abp.yaml --device cuda --sizes $n --steps $st --warmup 20 > $O/trace-run-$n.txt 2>&1
  python3 tools/gpu_trace/summarize.py /tmp/trace-$n.csv --skip 25 --count $((st - 10)) > $O/trace-$n-summary.txt 2>&1
  python3 tools/gpu_trace/summarize.py /tmp/trace-$n.csv --skip 25 --count $((st - 10)) --group 2 > $O/trace-$n-group2.txt 2>&1
  xz -c /tmp/trace-$n.csv > $O/trace-$n.csv.xz
  step trace-$n $?
done
echo done t=$SECONDS >> $I; pack
