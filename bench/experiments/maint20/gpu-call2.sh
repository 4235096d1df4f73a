#!/bin/bash
# (Kept for the record: run from gpu-carry/maint20 with summarize.py = tools/gpu_trace/summarize.py and
# run1's variants.tar.xz beside it.)
# maint20, call 2 (optional, short): where the time of detect_inversion, lawson and abp.integrate
# goes at 2^20, main's plugins against v1's (variants.tar.xz of run1.sh).
#   bash run2.sh BUNDLE OUT [ncu|trace|both]   (ncu, the default: ~60 s; trace ~60 s; both ~120 s)
#   writes OUT/run2.txt, OUT/ncu-v1.txt, OUT/trace-*.csv.xz
# 1. CUPTI timelines (BUNDLE/lib/libflipflow_gpu_trace.so), bench-abp 2^20, 30 steps after 5,
#    main then v1: per-kernel median durations and gaps (summarize.py, the repo's tools/gpu_trace);
# 2. ncu (if on PATH) of v1's kernels of these stages, one launch each after the warm-up:
#    SpeedOfLight, Occupancy, MemoryWorkloadAnalysis, WarpStateStats.
set -uo pipefail
SECONDS=0
B=$(cd "${1:?BUNDLE}" && pwd)
OUT=${2:?OUT}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
V=$B/m20
if [[ ! -d $V/v1 ]]; then
  mkdir -p "$V" && tar xJf "$HERE/variants.tar.xz" -C "$V"
fi
R=$OUT/run2.txt
WHAT=${3:-ncu}
{
  [[ $WHAT == ncu ]] || for v in main v1; do
    ((SECONDS < 70)) || break
    if [[ $v == main ]]; then unset FLIPFLOW_PLUGIN_PATH; else export FLIPFLOW_PLUGIN_PATH=$V/$v; fi
    echo "== CUPTI timeline, $v (from ${SECONDS} s)"
    CUDA_INJECTION64_PATH=$B/lib/libflipflow_gpu_trace.so FLIPFLOW_GPU_TRACE=$OUT/trace-$v.csv timeout 40 \
      "$B/bin/pipeline" bench "$B/pipelines/bench-abp.yaml" --device cuda --sizes 1048576 --steps 30 --warmup 5 \
      --results "$OUT/res-trace-$v" 2>&1 | grep -E "^[0-9]|rror" | head -3
    python3 "$HERE/summarize.py" "$OUT/trace-$v.csv" --skip 5 --count 30 2>&1 | head -60
    xz -f "$OUT/trace-$v.csv" 2>/dev/null
  done
  unset FLIPFLOW_PLUGIN_PATH
  if [[ $WHAT != trace ]] && command -v ncu > /dev/null && ((SECONDS < 80)); then
    echo "== ncu, v1 (from ${SECONDS} s)"
    FLIPFLOW_PLUGIN_PATH=$V/v1 timeout $((170 - SECONDS)) ncu --target-processes all --kernel-name-base demangled \
      --kernel-name regex:"mark_kernel|OverdampedStep|tail_kernel|MarkNonDelaunay|DecideMarked|ApplyMarked" \
      --launch-skip 60 --launch-count 7 --section SpeedOfLight --section Occupancy --section MemoryWorkloadAnalysis \
      --section WarpStateStats --section ComputeWorkloadAnalysis \
      "$B/bin/pipeline" bench "$B/pipelines/bench-abp.yaml" --device cuda --sizes 1048576 --steps 5 --warmup 10 \
      --results "$OUT/res-ncu" > "$OUT/ncu-v1.txt" 2>&1
    echo "ncu rc=$? (OUT/ncu-v1.txt)"
    grep -E "mark_kernel|OverdampedStep|tail_kernel|MarkNonDelaunay|DecideMarked|ApplyMarked|Duration|Memory Throughput|DRAM Throughput|Compute \(SM\)|Achieved Occupancy|L1/TEX Hit|L2 Hit|Registers Per" "$OUT/ncu-v1.txt" | head -80
  fi
  echo "total: ${SECONDS} s"
} 2>&1 | tee "$R"
