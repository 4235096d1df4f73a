#!/bin/bash
# frnn3, batch C (issue 17, neighbors.delaunay speed). Run from the repository root of main
# (tools/gpu_trace) with a bundle of main (0d00d5e):
#
#   BUNDLE=/path/to/bundle OUT=$OUT bash /work/main/gpu-carry/frnn3b/run.sh
#
# (CARRY=<this folder> if it is not at /work/main/gpu-carry/frnn3b.) Copies this folder to
# $BUNDLE/frnn3b/ (the .so files carry rpath $ORIGIN/../../lib). About 2.5 minutes; each step
# after the tests is skipped once BUDGET seconds (default 170) have passed:
#   1. tests: main's test_neighbors_delaunay with the f32q, f32qs and f32qsp plugins (f32, the branch's
#      source, passed in batch B), all at once;
#   2. speed: frnn-ab.yaml (bench-frnn.yaml with frnn_ab.main, .f32, .f32q, .f32qs, .f32qsp one after
#      another on the same state every step) at 2^16, 2^18, 2^20: stage ms per step;
#   3. kernels: a CUPTI trace of frnn-ab-rev.yaml (the reverse order) at 2^20, 30 steps: the
#      gather and search kernels of every variant in the same steps (the second round);
#   4. if time is left: the real plugins, bench-frnn.yaml at 2^20, main (-) vs f32qsp.
# Everything lands in $OUT/frnn3b/; summary.txt collects the lines to read.
set -uo pipefail
SECONDS=0
B=$(cd "${BUNDLE:-bundle}" && pwd)
C=${CARRY:-/work/main/gpu-carry/frnn3b}
O=${OUT:-out}/frnn3b
BUDGET=${BUDGET:-170}
mkdir -p "$O" "$B/frnn3b"
cp -r "$C"/. "$B/frnn3b/"
V=$B/frnn3b
S=$O/summary.txt
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv | tee "$S"
left() { ((SECONDS < BUDGET)) || { echo "== skipped ($1): ${SECONDS} s spent" | tee -a "$S"; return 1; }; }

# 1. tests (in parallel; the CPU cases run too)
for v in f32q f32qs f32qsp; do
  (FLIPFLOW_TEST_DEVICE=cuda FLIPFLOW_PLUGIN_PATH=$V/$v:$B/plugins timeout 90 "$B/bin/test_neighbors_delaunay" \
     > "$O/test-$v.log" 2>&1; echo "rc=$?" >> "$O/test-$v.log") &
done
wait
for v in f32q f32qs f32qsp; do echo "== test_neighbors_delaunay $v: $(tail -n 3 "$O/test-$v.log" | tr '\n' ' ')"; done | tee -a "$S"
echo "tests done at ${SECONDS} s" | tee -a "$S"

# 2. stage ms, one process
if left ab; then
  FLIPFLOW_PLUGIN_PATH=$V/ab timeout 150 "$B/bin/pipeline" bench "$V/frnn-ab.yaml" --device cuda --sizes 2^16,2^18,2^20 \
    --steps 100 --warmup 20 --results "$O/results" > "$O/frnn-ab.txt" 2>&1
  echo "== frnn-ab rc=$? at ${SECONDS} s" | tee -a "$S"
  grep -E "^[0-9]|max_visited" "$O/frnn-ab.txt" | tee -a "$S"
fi

# 3. kernel medians at 2^20, reverse order
if left trace && [[ -f $B/lib/libflipflow_gpu_trace.so ]]; then
  FLIPFLOW_PLUGIN_PATH=$V/ab CUDA_INJECTION64_PATH=$B/lib/libflipflow_gpu_trace.so FLIPFLOW_GPU_TRACE=$O/trace.csv \
    timeout 90 "$B/bin/pipeline" bench "$V/frnn-ab-rev.yaml" --device cuda --sizes 2^20 --steps 30 --warmup 5 \
    --results "$O/results" > "$O/trace.out" 2>&1
  echo "== trace rc=$? at ${SECONDS} s" | tee -a "$S"
  grep -E "^[0-9]" "$O/trace.out" | tee -a "$S"
  /usr/bin/python3 tools/gpu_trace/summarize.py "$O/trace.csv" --step-marker OverdampedStep --skip 5 --count 30 \
    > "$O/trace.txt" 2>&1
  rm -f "$O/trace.csv"
  sed -n '/^Per name/,$p' "$O/trace.txt" | grep -E "Per name|frnn_ab" | cut -c1-200 | tee -a "$S"
fi

# 4. the real plugins in the real pipeline
if left real; then
  SIZES=2^20 ROUNDS=1 STEPS=100 WARMUP=20 SHOW="max_visited|capacity" PIPELINE_BIN=$B/bin/pipeline timeout 120 \
    tools/bench/plugin_ab.sh "$B/pipelines/bench-frnn.yaml" - "$V/f32qsp" > "$O/real.txt" 2>&1
  echo "== real rc=$? at ${SECONDS} s" | tee -a "$S"
  cat "$O/real.txt" >> "$S"
fi
echo "total ${SECONDS} s" | tee -a "$S"
