#!/bin/bash
# frnn3 (issue 17, neighbors.delaunay speed): GPU batch. Run from the repository root of main
# (tools/bench, tools/gpu_trace) with a bundle of main (0d00d5e):
#
#   BUNDLE=/path/to/bundle OUT=$OUT bash /work/main/gpu-carry/frnn3/run.sh
#
# (CARRY=<this folder> if it is not at /work/main/gpu-carry/frnn3.) Copies this folder to
# $BUNDLE/frnn3/ (the .so files carry rpath $ORIGIN/../../lib). Steps, each skipped once the
# script has run BUDGET seconds (default 170), in this order of value:
#   1. tests: main's test_neighbors_delaunay (brute force on CUDA, CPU == CUDA rows, the 10^3-step
#      hard-disk run against neighbors.verlet, capacity growth) with each variant's
#      libflipflow_stage_neighbors.so (csr, tile8, tile8pf, f32), the four at once;
#   2. speed: frnn-ab.yaml = bench-frnn.yaml with all five searches (main, csr, tile8, tile8pf, f32)
#      as stages frnn_ab.<v> of one plugin, one after another on the same state every step, at
#      2^16, 2^18, 2^20;
#   3. a CUPTI trace of frnn-ab.yaml at 2^20 (30 steps): gather vs search kernel per variant;
#   4. the baseline: bundle's bench-frnn-verlet.yaml (neighbors.verlet rebuilt every step, r = 2σ);
#   2b. round 2 of step 2 in the reverse order (frnn-ab-rev.yaml);
#   5. if time is left: the real plugins, bench-frnn.yaml at 2^20, main (-) vs csr.
# Everything lands in $OUT/frnn3/; summary.txt collects the lines to read.
set -uo pipefail
SECONDS=0
B=$(cd "${BUNDLE:-bundle}" && pwd)
C=${CARRY:-/work/main/gpu-carry/frnn3}
O=${OUT:-out}/frnn3
BUDGET=${BUDGET:-170}
mkdir -p "$O" "$B/frnn3"
cp -r "$C"/. "$B/frnn3/"
V=$B/frnn3
S=$O/summary.txt
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv | tee "$S"
left() { ((SECONDS < BUDGET)) || { echo "== skipped ($1): ${SECONDS} s spent" | tee -a "$S"; return 1; }; }

# 1. tests (in parallel; the CPU cases run too)
for v in csr tile8 tile8pf f32; do
  (FLIPFLOW_TEST_DEVICE=cuda FLIPFLOW_PLUGIN_PATH=$V/$v:$B/plugins timeout 90 "$B/bin/test_neighbors_delaunay" \
     > "$O/test-$v.log" 2>&1; echo "rc=$?" >> "$O/test-$v.log") &
done
wait
for v in csr tile8 tile8pf f32; do echo "== test_neighbors_delaunay $v: $(tail -n 3 "$O/test-$v.log" | tr '\n' ' ')"; done | tee -a "$S"
echo "tests done at ${SECONDS} s" | tee -a "$S"

# 2. A/B in one process (the stages' ms: the neighbors.delaunay-like columns frnn_ab.<v>)
ab_round() {
  local y=$1
  left "$y" || return
  FLIPFLOW_PLUGIN_PATH=$V/ab timeout 150 "$B/bin/pipeline" bench "$V/$y.yaml" --device cuda --sizes 2^16,2^18,2^20 \
    --steps 100 --warmup 20 --results "$O/results" > "$O/$y.txt" 2>&1
  echo "== $y rc=$? at ${SECONDS} s" | tee -a "$S"
  grep -E "^[0-9]|max_visited|capacity" "$O/$y.txt" | tee -a "$S"
}
ab_round frnn-ab

# 3. kernel breakdown at 2^20 (per-kernel medians)
if left trace && [[ -f $B/lib/libflipflow_gpu_trace.so ]]; then
  FLIPFLOW_PLUGIN_PATH=$V/ab CUDA_INJECTION64_PATH=$B/lib/libflipflow_gpu_trace.so FLIPFLOW_GPU_TRACE=$O/trace.csv \
    timeout 60 "$B/bin/pipeline" bench "$V/frnn-ab.yaml" --device cuda --sizes 2^20 --steps 30 --warmup 5 \
    --results "$O/results" > "$O/trace.out" 2>&1
  /usr/bin/python3 tools/gpu_trace/summarize.py "$O/trace.csv" --step-marker OverdampedStep --skip 5 --count 30 \
    > "$O/trace.txt" 2>&1
  rm -f "$O/trace.csv"
  echo "== trace at ${SECONDS} s" | tee -a "$S"
  grep -iE "frnn_ab|name" "$O/trace.txt" | tail -n 30 | cut -c1-220 | tee -a "$S"
fi

# 4. Verlet rebuilt every step, same radius
if left verlet; then
  timeout 90 "$B/bin/pipeline" bench "$B/pipelines/bench-frnn-verlet.yaml" --device cuda --sizes 2^16,2^18,2^20 \
    --steps 100 --warmup 20 --results "$O/results" > "$O/verlet.txt" 2>&1
  echo "== verlet rc=$? at ${SECONDS} s" | tee -a "$S"
  grep -E "^[0-9]|rebuilds|max_neighbors" "$O/verlet.txt" | tee -a "$S"
fi

# 2b. the second round, in the reverse order
ab_round frnn-ab-rev

# 5. the real plugins in the real pipeline (confirms the one-process A/B)
if left real; then
  SIZES=2^20 ROUNDS=1 STEPS=100 WARMUP=20 SHOW="max_visited|capacity" PIPELINE_BIN=$B/bin/pipeline timeout 120 \
    tools/bench/plugin_ab.sh "$B/pipelines/bench-frnn.yaml" - "$V/csr" > "$O/real.txt" 2>&1
  echo "== real rc=$? at ${SECONDS} s" | tee -a "$S"
  cat "$O/real.txt" >> "$S"
fi
echo "total ${SECONDS} s" | tee -a "$S"
