#!/bin/bash
# voronoi.geometry CUDA variants (issue 18: ≤ 0.1 ms per call at 2^20 on the H100), run from the
# repository root with a bundle of main:
#
#   BUNDLE=/tmp/bundle CARRY=gpu-carry/vspeed OUT=$OUT bash gpu-carry/vspeed/voronoi-gpu-variants.sh
#
# VARIANTS="a b": only these variant folders, in this order (default: every folder with a plugin);
# BITS=0 skips step 1; TRACE=none skips step 3 (TRACE="": main's trace only).
# CARRY holds one folder per variant with its libflipflow_stage_voronoi.so, and tests/ with the
# branch's test_voronoi_geometry; the script copies them to $BUNDLE/vspeed/ (two folders below
# the bundle root: their rpath is $ORIGIN/../../lib). Steps:
#   1. bits: the branch's test_voronoi_geometry (CPU == CUDA bit for bit, the metrics equal the
#      fixed-point sums of the stored cells on three calls in a row, corrupt fans) against every
#      variant's plugin;
#   2. speed: tools/bench/plugin_ab.sh on pipelines/bench-voronoi.yaml (hard disks, η = 0.5) at
#      SIZES (default 2^20), main's plugins (-) against every variant, interleaved, ROUNDS (2);
#   3. where the time goes: a CUPTI trace of one 2^20 bench of main and of the variants named in
#      TRACE (default: every variant), summarized per kernel (tools/gpu_trace), each only while
#      the script has run less than BUDGET seconds (default 150).
# Logs go to $OUT (bits.txt, ab.txt, trace-<variant>.txt).
set -uo pipefail
SECONDS=0
B=${BUNDLE:-bundle}
C=${CARRY:-gpu-carry/vspeed}
OUT=${OUT:-/tmp/vspeed}
mkdir -p "$OUT" "$B/vspeed"
B=$(cd "$B" && pwd)
cp -r "$C"/. "$B/vspeed/"
V=$B/vspeed
variants=()
if [[ -n ${VARIANTS:-} ]]; then  # these folders, in this order
  for name in $VARIANTS; do variants+=("$V/$name"); done
else
  for d in "$V"/*/; do
    d=${d%/}
    [[ -f $d/libflipflow_stage_voronoi.so ]] && variants+=("$d")
  done
fi
echo "variants: ${variants[*]}" | tee "$OUT/ab.txt"
nvidia-smi -L | tee -a "$OUT/ab.txt"

# 1. bits (BITS=0 skips them)
: > "$OUT/bits.txt"
((${BITS:-1})) && for d in "${variants[@]}"; do
  echo "== $(basename "$d")"
  FLIPFLOW_PLUGIN_PATH=$d:$B/plugins timeout 120 "$V/tests/test_voronoi_geometry" 2>&1 | tail -4
done > "$OUT/bits.txt" 2>&1
cat "$OUT/bits.txt"

# 2. speed
SIZES=${SIZES:-2^20} ROUNDS=${ROUNDS:-2} SHOW="voronoi.geometry/area_(mean|sum)|iterations per" \
  PIPELINE_BIN=$B/bin/pipeline tools/bench/plugin_ab.sh "$B/pipelines/bench-voronoi.yaml" - "${variants[@]}" 2>&1 |
  tee -a "$OUT/ab.txt"

# 3. traces (kernel medians of the back-to-back pass)
if [[ -f $B/lib/libflipflow_gpu_trace.so && ${TRACE-} != none ]]; then
  for name in main ${TRACE-$(for d in "${variants[@]}"; do basename "$d"; done)}; do
    if ((SECONDS > ${BUDGET:-150})); then echo "== trace $name skipped: ${SECONDS} s spent"; continue; fi
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
echo "total: ${SECONDS} s"
