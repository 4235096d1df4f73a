#!/bin/bash
# ljgpu (issue 16, session 13): lj-aggregation at 2^20 on CUDA, main's plugins against the branch's
# variants. Run as gpu-carry/ljgpu/run.sh beside its libs/ and tests/ (copied there from this file):
#
#   BUNDLE=/tmp/bundle OUT=$OUT bash gpu-carry/ljgpu/run.sh      (from the repository root)
#
# libs/: neighbors-ahead.so (libflipflow_stage_neighbors.so of dc65805), neighbors-fused.so and
# overdamped-fused.so (754c66a), pair-pipe.so (libflipflow_plugin_pair.so of 1e5602b), and
# pair-{pipe3,pipe2,occ5,pipen}.so: the branch with bench/experiments/lj-s13/pair-*.patch applied;
# each with `patchelf --force-rpath --set-rpath '$ORIGIN/../../lib'`. tests/test_pair_cuda_run:
# the branch's (the same rpath).
#
# BUNDLE: a bundle of main (29a3dee: bin/, lib/, plugins/, pipelines/). The script copies this
# folder's libraries into BUNDLE/ljgpu/<variant>/ (two folders below the bundle root, where their
# rpath $ORIGIN/../../lib finds the bundle's lib/) and its test binary into BUNDLE/ljgpu/tests/.
#   1. bits  (bits.txt): the CUDA tests of the touched stages against each variant's plugins;
#   2. speed (ab.txt): tools/bench/plugin_ab.sh, 2^20, 100 steps after 20, 2 rounds interleaved;
#   3. where the time goes (trace-<variant>.txt): a CUPTI trace of 30 bench steps of main and
#      fused (a step from one pair.lj sum kernel to the next).
set -u
B=$(cd "${BUNDLE:?set BUNDLE to the bundle of main}" && pwd)
OUT=${OUT:?set OUT}
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
root=$(cd "$here/../.." && pwd)
mkdir -p "$OUT"
t0=$(date +%s)
el() { echo "[$(( $(date +%s) - t0 )) s] $*" | tee -a "$OUT/timeline.txt"; }
nvidia-smi -L > "$OUT/gpu.txt" 2>&1

V=$B/ljgpu
rm -rf "$V" && mkdir -p "$V/tests"
cp "$here/tests/test_pair_cuda_run" "$V/tests/"
variant() {  # variant NAME LIB...  (libs/neighbors-*.so -> libflipflow_stage_neighbors.so, and so on)
  local name=$1 lib
  shift
  mkdir -p "$V/$name"
  for lib in "$@"; do
    case $lib in
      neighbors-*) cp "$here/libs/$lib" "$V/$name/libflipflow_stage_neighbors.so" ;;
      pair-*) cp "$here/libs/$lib" "$V/$name/libflipflow_plugin_pair.so" ;;
      overdamped-*) cp "$here/libs/$lib" "$V/$name/libflipflow_stage_overdamped.so" ;;
    esac
  done
}
variant ahead neighbors-ahead.so
variant ahead-pipe neighbors-ahead.so pair-pipe.so
variant ahead-pipe3 neighbors-ahead.so pair-pipe3.so
variant ahead-pipe2 neighbors-ahead.so pair-pipe2.so
variant ahead-occ5 neighbors-ahead.so pair-occ5.so
variant fused neighbors-fused.so overdamped-fused.so pair-pipe.so
variant fused-n neighbors-fused.so overdamped-fused.so pair-pipen.so
# (the batch runs under a 150 s limit: pipe2 and occ5, the least likely, are left out of it; add
# them back to NAMES to run them)
names=(${NAMES:-fused fused-n ahead-pipe ahead ahead-pipe3})
el "variants: ${names[*]}"

# 1. bits. test_pair_cuda_run: neighbors.verlet + pair.lj + overdamped.integrate (max_step) for
# 1000 steps (rebuilds, rollbacks): CUDA's metrics every step and final fields == the CPU's.
# test_pair_lj [cuda]: pair.lj CPU vs CUDA memcmp; test_neighbors_verlet: the list tests on both
# backends (the rebuild test's decisions step by step).
{
  for n in "${names[@]}"; do
    echo "== $n"
    export FLIPFLOW_PLUGIN_PATH=$V/$n:$B/plugins
    (cd /tmp && timeout 60 "$V/tests/test_pair_cuda_run" 2>&1 | tail -3)
    # (ahead has main's pair.lj)
    [[ $n == ahead ]] || (cd /tmp && timeout 60 "$B/bin/test_pair_lj" "[cuda]" 2>&1 | tail -3)
  done
  for n in fused; do
    echo "== $n: test_neighbors_verlet"
    FLIPFLOW_PLUGIN_PATH=$V/$n:$B/plugins timeout 90 "$B/bin/test_neighbors_verlet" 2>&1 | tail -2
  done
  for t in test_pair_blowup test_overdamped_integrate test_overdamped_non_finite; do
    echo "== fused: $t"
    (cd /tmp && FLIPFLOW_PLUGIN_PATH=$V/fused:$B/plugins timeout 60 "$B/bin/$t" 2>&1 | tail -2)
  done
  echo "== main (bundle): test_pair_cuda_run"
  FLIPFLOW_PLUGIN_PATH=$B/plugins timeout 60 "$V/tests/test_pair_cuda_run" 2>&1 | tail -3
  unset FLIPFLOW_PLUGIN_PATH
} > "$OUT/bits.txt" 2>&1
el "bits done"; grep -E "^==|passed|failed|FAILED" "$OUT/bits.txt"

# 2. speed: main's plugins (-) against every variant, interleaved, two rounds, 2^20.
cd "$root"
SIZES=${SIZES:-2^20} ROUNDS=${ROUNDS:-2} SHOW="rebuilds per|rollbacks per" PIPELINE_BIN=$B/bin/pipeline \
  timeout 100 tools/bench/plugin_ab.sh "$B/pipelines/lj-aggregation.yaml" - "${names[@]/#/$V/}" > "$OUT/ab.txt" 2>&1
el "speed done"; cat "$OUT/ab.txt"

# 3. traces: kernel medians of the back-to-back pass (tools/gpu_trace).
if [[ -f $B/lib/libflipflow_gpu_trace.so ]]; then
  for name in main fused; do
    if [[ $name == main ]]; then unset FLIPFLOW_PLUGIN_PATH; else export FLIPFLOW_PLUGIN_PATH=$V/$name; fi
    CUDA_INJECTION64_PATH=$B/lib/libflipflow_gpu_trace.so FLIPFLOW_GPU_TRACE=$OUT/trace-$name.csv \
      timeout 25 "$B/bin/pipeline" bench "$B/pipelines/lj-aggregation.yaml" --device cuda --sizes 2^20 --steps 30 \
      --warmup 5 --results "$OUT/results" > /dev/null 2>&1
    /usr/bin/python3 tools/gpu_trace/summarize.py "$OUT/trace-$name.csv" --step-marker force_kernel --skip 5 --count 30 \
      > "$OUT/trace-$name.txt" 2>&1
    rm -f "$OUT/trace-$name.csv"
    echo "== trace $name"; head -40 "$OUT/trace-$name.txt"
  done
  unset FLIPFLOW_PLUGIN_PATH
fi
el "all done"
