#!/bin/bash
# voronoi.geometry CUDA variants (issue 18: ≤ 0.1 ms per call at 2^20 on the H100), run from the
# repository root with a bundle of main:
#
#   BUNDLE=/tmp/bundle CARRY=gpu-carry/vspeed OUT=$OUT bash gpu-carry/vspeed/voronoi-gpu-variants.sh
#
# CARRY holds one folder per variant with its libflipflow_stage_voronoi.so, and tests/ with the
# branch's test_voronoi_geometry; the script copies them to $BUNDLE/vspeed/ (two folders below
# the bundle root: their rpath is $ORIGIN/../../lib). Steps:
#   1. bits: the branch's test_voronoi_geometry (CPU == CUDA bit for bit, the metrics equal the
#      fixed-point sums of the stored cells on three calls in a row, corrupt fans) against every
#      variant's plugin;
#   2. speed: tools/bench/plugin_ab.sh on pipelines/bench-voronoi.yaml (hard disks, η = 0.5) at
#      2^18 and 2^20, main's plugins (-) against every variant, interleaved, two rounds;
#   3. where the time goes: a CUPTI trace of one 2^20 bench of main and of the variants named in
#      TRACE (default: fused), summarized per kernel (tools/gpu_trace).
# Logs go to $OUT (bits.txt, ab.txt, trace-<variant>.txt).
set -uo pipefail
B=${BUNDLE:-bundle}
C=${CARRY:-gpu-carry/vspeed}
OUT=${OUT:-/tmp/vspeed}
mkdir -p "$OUT" "$B/vspeed"
B=$(cd "$B" && pwd)
cp -r "$C"/. "$B/vspeed/"
V=$B/vspeed
variants=()
for d in "$V"/*/; do
  d=${d%/}
  [[ -f $d/libflipflow_stage_voronoi.so ]] && variants+=("$d")
done
echo "variants: ${variants[*]}" | tee "$OUT/ab.txt"
nvidia-smi -L | tee -a "$OUT/ab.txt"

# 1. bits
for d in "${variants[@]}"; do
  echo "== $(basename "$d")"
  FLIPFLOW_PLUGIN_PATH=$d:$B/plugins timeout 120 "$V/tests/test_voronoi_geometry" 2>&1 | tail -4
done > "$OUT/bits.txt" 2>&1
cat "$OUT/bits.txt"

# 2. speed
SIZES=${SIZES:-2^18,2^20} ROUNDS=${ROUNDS:-2} SHOW="voronoi.geometry/area_(mean|sum)|iterations per" \
  PIPELINE_BIN=$B/bin/pipeline tools/bench/plugin_ab.sh "$B/pipelines/bench-voronoi.yaml" - "${variants[@]}" 2>&1 |
  tee -a "$OUT/ab.txt"

# 3. traces (kernel medians of the back-to-back pass)
if [[ -f $B/lib/libflipflow_gpu_trace.so ]]; then
  for name in main ${TRACE-fused}; do
    if [[ $name == main ]]; then unset FLIPFLOW_PLUGIN_PATH; else export FLIPFLOW_PLUGIN_PATH=$V/$name; fi
    CUDA_INJECTION64_PATH=$B/lib/libflipflow_gpu_trace.so FLIPFLOW_GPU_TRACE=$OUT/trace-$name.csv \
      "$B/bin/pipeline" bench "$B/pipelines/bench-voronoi.yaml" --device cuda --sizes 2^20 --steps 30 --warmup 5 \
      --results "$OUT/results" > /dev/null 2>&1
    /usr/bin/python3 tools/gpu_trace/summarize.py "$OUT/trace-$name.csv" --step-marker MarkInversions --skip 5 \
      --count 30 > "$OUT/trace-$name.txt" 2>&1
    rm -f "$OUT/trace-$name.csv"
    echo "== trace $name"; head -45 "$OUT/trace-$name.txt"
  done
fi
