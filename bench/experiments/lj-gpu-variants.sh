#!/bin/bash
# pair.lj CUDA loop variants (issue 16's H100 benchmark), run from a bundle of main:
#
#   BUNDLE=bundle VARIANTS=bundle/ljgpu OUT=$OUT bench/experiments/lj-gpu-variants.sh
#
# VARIANTS holds one folder per variant with its libflipflow_plugin_pair.so (rpath
# $ORIGIN/../../lib: two folders below the bundle root) and tests/test_pair_lj_cpu_cuda, the
# pair.lj CPU-vs-CUDA tests of the branch (rpath the same; a branch from before test_lj.cpp was
# split by subject carries tests/test_pair_lj, whose "[cuda]" cases they were). Steps:
#   1. bits: the branch's pair.lj CUDA tests ("CPU and CUDA give the same bits", also over moving
#      steps with rebuilds) against every variant's plugin;
#   2. speed: tools/bench/plugin_ab.sh on pipelines/lj-aggregation.yaml at 2^18 and 2^20, main's
#      plugins (-) against every variant, interleaved, two rounds;
#   3. where the time goes: a CUPTI trace of one 2^20 bench of main and of the variants named
#      in TRACE (tools/gpu_trace), summarized per kernel.
# Logs go to $OUT (bits.txt, ab.txt, trace-<variant>.txt).
set -uo pipefail
B=${BUNDLE:-bundle}
V=${VARIANTS:-$B/ljgpu}
OUT=${OUT:-/tmp/ljgpu}
mkdir -p "$OUT"
variants=()
for d in "$V"/*/; do
  d=${d%/}
  [[ -f $d/libflipflow_plugin_pair.so ]] && variants+=("$d")
done
echo "variants: ${variants[*]}" | tee "$OUT/ab.txt"

# 1. bits
bits=("$V/tests/test_pair_lj_cpu_cuda")
[[ -x ${bits[0]} ]] || bits=("$V/tests/test_pair_lj" "[cuda]")
for d in "${variants[@]}"; do
  echo "== $(basename "$d")"
  FLIPFLOW_PLUGIN_PATH=$d:$B/plugins "${bits[@]}" 2>&1 | tail -4
done > "$OUT/bits.txt" 2>&1
cat "$OUT/bits.txt"

# 2. speed
SIZES=${SIZES:-2^18,2^20} ROUNDS=${ROUNDS:-2} SHOW="rebuilds per|max_neighbors per" PIPELINE_BIN=$B/bin/pipeline \
  tools/bench/plugin_ab.sh "$B/pipelines/lj-aggregation.yaml" - "${variants[@]}" 2>&1 | tee -a "$OUT/ab.txt"

# 3. traces (kernel medians of the back-to-back pass)
if [[ -f $B/lib/libflipflow_gpu_trace.so ]]; then
  for name in main ${TRACE:-}; do
    if [[ $name == main ]]; then unset FLIPFLOW_PLUGIN_PATH; else export FLIPFLOW_PLUGIN_PATH=$V/$name; fi
    CUDA_INJECTION64_PATH=$PWD/$B/lib/libflipflow_gpu_trace.so FLIPFLOW_GPU_TRACE=$OUT/trace-$name.csv \
      "$B/bin/pipeline" bench "$B/pipelines/lj-aggregation.yaml" --device cuda --sizes 2^20 --steps 30 --warmup 5 \
      --results "$OUT/results" > /dev/null 2>&1
    /usr/bin/python3 tools/gpu_trace/summarize.py "$OUT/trace-$name.csv" --step-marker MovedTooFar --skip 5 --count 30 \
      > "$OUT/trace-$name.txt" 2>&1
    rm -f "$OUT/trace-$name.csv"
    echo "== trace $name"; head -40 "$OUT/trace-$name.txt"
  done
fi
