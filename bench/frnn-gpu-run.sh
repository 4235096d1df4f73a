#!/bin/bash
# frnn (issue 17): neighbors.delaunay variants v1, v2, v3 (libflipflow_stage_neighbors.so)
# against main's, on the H100. Run from the repository root of main, with bundle/ built from main
# and this folder copied to bundle/frnn/ (the .so files and bin/ carry the rpath $ORIGIN/../../lib):
#   cp -r /work/main/gpu-carry/frnn bundle/frnn && OUT=$OUT bash bundle/frnn/run.sh
# Writes logs under $OUT/frnn. About 2 minutes.
set -u
B=${BUNDLE:-bundle}
F=$PWD/$B/frnn
O=${OUT:-out}/frnn
mkdir -p "$O"
export PIPELINE_BIN=$PWD/$B/bin/pipeline
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv > "$O/gpu.txt" 2>&1
# 1. Correctness on the GPU: main's test of the stage (brute force on CUDA, CPU vs CUDA rows,
#    the 10^3-step hard-disk run against neighbors.verlet, the phoretic bit test) with v3, and
#    its CPU-vs-CUDA case with v1 and v2.
FLIPFLOW_PLUGIN_PATH=$F/v3 timeout 150 "$B/bin/test_neighbors_delaunay" > "$O/test-v3.log" 2>&1
echo "test_neighbors_delaunay v3 rc=$?" | tee -a "$O/summary.txt"
for v in v1 v2; do
  FLIPFLOW_PLUGIN_PATH=$F/$v timeout 60 "$B/bin/test_neighbors_delaunay" "[cuda]" > "$O/test-$v.log" 2>&1
  echo "test_neighbors_delaunay [cuda] $v rc=$?" | tee -a "$O/summary.txt"
done
# The tests this branch adds (built against main's core at 02b9853): boids with either neighbour
# source bit for bit, and sub-steps in a running pipeline, on CPU and CUDA.
export FLIPFLOW_PLUGIN_PATH=$F/v3:$PWD/$B/plugins
timeout 90 "$F/bin/test_boids_delaunay" > "$O/test-boids-delaunay.log" 2>&1
echo "test_boids_delaunay (v3) rc=$?" | tee -a "$O/summary.txt"
timeout 60 "$F/bin/test_delaunay_flip" "[substep]" > "$O/test-flip-substep.log" 2>&1
echo "test_delaunay_flip [substep] rc=$?" | tee -a "$O/summary.txt"
unset FLIPFLOW_PLUGIN_PATH
tail -n 3 "$O"/test-*.log >> "$O/summary.txt"
# 2. Timings, interleaved: main's plugins (-), v1, v2, v3 on the Delaunay pipeline; Verlet
#    rebuilt every step at the same radius as the baseline to beat; the parent traversal.
export SIZES=2^16,2^18,2^20 ROUNDS=2 STEPS=100 WARMUP=20 SHOW="max_visited|capacity"
timeout 300 tools/bench/plugin_ab.sh pipelines/bench-frnn.yaml - "$F/v1" "$F/v2" "$F/v3" > "$O/ab-delaunay.txt" 2>&1
echo "ab delaunay rc=$?" >> "$O/summary.txt"
ROUNDS=1 timeout 90 tools/bench/plugin_ab.sh pipelines/bench-frnn-verlet.yaml - > "$O/ab-verlet.txt" 2>&1
echo "ab verlet rc=$?" >> "$O/summary.txt"
ROUNDS=1 timeout 90 tools/bench/plugin_ab.sh "$F/frnn-parent.yaml" - "$F/v3" > "$O/ab-parent.txt" 2>&1
echo "ab parent rc=$?" >> "$O/summary.txt"
# 3. Kernel breakdown at 2^20 (CUPTI trace): main vs v3.
for v in main v3; do
  if [[ $v == main ]]; then unset FLIPFLOW_PLUGIN_PATH; else export FLIPFLOW_PLUGIN_PATH=$F/$v; fi
  CUDA_INJECTION64_PATH=$PWD/$B/lib/libflipflow_gpu_trace.so FLIPFLOW_GPU_TRACE=$O/trace-$v.csv timeout 60 \
    "$B/bin/pipeline" bench pipelines/bench-frnn.yaml --device cuda --sizes 2^20 --steps 30 --warmup 5 > "$O/trace-$v.out" 2>&1
  /usr/bin/python3 tools/gpu_trace/summarize.py "$O/trace-$v.csv" --step-marker OverdampedStep --skip 5 --count 30 \
    > "$O/trace-$v.txt" 2>&1
  rm -f "$O/trace-$v.csv"
done
unset FLIPFLOW_PLUGIN_PATH
cat "$O/summary.txt"
