#!/bin/bash
# GPU request of branch i20-overlap (issue 20): overlap_correct's walls/mark as compile-time
# variants, against main and against the stage as it was before walls existed (bc2eb5c's
# stages/overlap_correct built against today's core: a plugin built at bc2eb5c itself has ABI 1
# and does not load). Run from the repository root with a bundle of main:
#
#   cp -r /work/main/gpu-carry/overlap bundle/overlap   # bundle/overlap/{main,fix,prewalls}/*.so, tests/
#   BUNDLE=bundle OUT=$OUT bash bundle/overlap/overlap_correct-gpu_ab.sh
#
# 1. bits: CPU vs CUDA with the fix's plugin (the no-walls/no-mark, walls and mark kernels);
# 2. bench-abp at 2^14 and 2^20, hard-spheres (overlap_correct.verlet, 3D) at 2^20: main, fix and
#    prewalls interleaved (tools/bench/plugin_ab.sh, 2 rounds). Writes $OUT/overlap-ab.txt.
set -u
B=${BUNDLE:-bundle}
V=${VARIANTS:-$B/overlap}
OUT=${OUT:-/tmp}
P=$B/pipelines
[[ -d $P ]] || P=pipelines
export PIPELINE_BIN=$B/bin/pipeline
{
  nvidia-smi --query-gpu=name,clocks.sm,clocks.mem --format=csv 2>/dev/null
  echo "== bits (fix): CPU vs CUDA"
  # The CPU-vs-CUDA cases are test_overlap_correct_cpu_cuda's since test_overlap_correct.cpp was
  # split by subject; carried test binaries from before that have them in test_overlap_correct.
  if [[ -x $V/tests/test_overlap_correct_cpu_cuda ]]; then
    FLIPFLOW_PLUGIN_PATH=$V/fix:$B/plugins timeout 150 $V/tests/test_overlap_correct_cpu_cuda 2>&1 | tail -3
    FLIPFLOW_PLUGIN_PATH=$V/fix:$B/plugins timeout 150 $V/tests/test_overlap_correct "[mark]" 2>&1 | tail -3
  else
    FLIPFLOW_PLUGIN_PATH=$V/fix:$B/plugins timeout 150 $V/tests/test_overlap_correct "[cuda],[mark]" 2>&1 | tail -3
  fi
  FLIPFLOW_PLUGIN_PATH=$V/fix:$B/plugins timeout 150 $V/tests/test_overlap_correct_walls "[cuda]" 2>&1 | tail -3
  FLIPFLOW_PLUGIN_PATH=$V/fix:$B/plugins timeout 150 $V/tests/test_overlap_correct_verlet "[determinism]" 2>&1 | tail -3
  echo "== bench-abp 2^14, 2^20"
  SIZES=2^14,2^20 ROUNDS=2 tools/bench/plugin_ab.sh $P/bench-abp.yaml $V/main $V/fix $V/prewalls
  echo "== hard-spheres 2^20"
  SIZES=2^20 ROUNDS=2 SHOW="iterations per|list_rebuilds per" tools/bench/plugin_ab.sh $P/hard-spheres.yaml \
    $V/main $V/fix $V/prewalls
} 2>&1 | tee "$OUT/overlap-ab.txt"
