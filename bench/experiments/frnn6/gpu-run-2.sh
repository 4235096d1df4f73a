#!/bin/bash
# frnn6, GPU call 2 (issue 17, neighbors.delaunay search speed; branch frnn6). One H200, < 3 min.
#
#   bash gpu-carry/frnn6/gpu-run-2.sh BUNDLE OUT      (BUNDLE: the extracted bundle of main, ABI 5)
#
# Call 1 (gpu-run.sh) measured the flat search loops against main; this call checks the branch's
# source (`src`: the winner made the source, the branch's own stages/neighbors/delaunay) and
# times the refinements in ab2.yaml (listed there) against main in one process.
# Steps:
#   1. ab2.yaml at 2^20: main, src, the refinements, main2 and neighbors.verlet rebuilt every
#      step at r = 2σ, one process, same state, 100 steps after 20;
#   2. test_neighbors_delaunay and test_boids_delaunay with src's stage plugin on CUDA, and
#      test_neighbors_delaunay with each refinement's;
#   3. pipelines/bench-frnn.yaml at 2^20 with src's stage plugin (the issue's own benchmark), and
#      bench-frnn-verlet.yaml (the baseline in its own pipeline), if < 120 s have passed;
#   4. boids at 2^20 (bench-boids-delaunay.yaml) with src's stage (dense flocks: searches past
#      16 queue slots), if < 135 s have passed.
# $OUT/frnn6b/summary.txt collects the lines to read.
set -uo pipefail
SECONDS=0
B=$(cd "${1:-${BUNDLE:-bundle}}" && pwd)
OUTDIR=${2:-${OUT:-out}}
C=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
O=$OUTDIR/frnn6b
DEVICE=${DEVICE:-cuda}
SIZES=${SIZES:-2^20}
V=$B/frnn6b
mkdir -p "$O" "$V"
cp "$C"/ab2.yaml "$V/"
tar xJf "$C/so2.tar.xz" -C "$V"  # ab/ (the ab2 stages) and one folder per stage plugin (src, refinements)
S=$O/summary.txt
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv > "$S" 2>&1
cat "$S"

# 1. one process, same state each step
FLIPFLOW_PLUGIN_PATH=$V/ab timeout 75 "$B/bin/pipeline" bench "$V/ab2.yaml" --device "$DEVICE" --sizes "$SIZES" \
  --steps 100 --warmup 20 --results "$O/results-ab2" > "$O/ab2.txt" 2>&1
echo "== ab2 rc=$? at ${SECONDS} s" | tee -a "$S"
grep -E "^ *[0-9]|max_visited|error" "$O/ab2.txt" | tee -a "$S"

# 2. tests
PLUGINS=$(cd "$V" && ls -d */ | tr -d / | grep -v '^ab$')
for v in $PLUGINS; do
  (FLIPFLOW_TEST_DEVICE=$DEVICE FLIPFLOW_PLUGIN_PATH=$V/$v:$B/plugins timeout 60 "$B/bin/test_neighbors_delaunay" \
     > "$O/test-$v.log" 2>&1; echo "rc=$?" >> "$O/test-$v.log") &
done
(FLIPFLOW_TEST_DEVICE=$DEVICE FLIPFLOW_PLUGIN_PATH=$V/src:$B/plugins timeout 60 "$B/bin/test_boids_delaunay" \
   > "$O/test-boids-src.log" 2>&1; echo "rc=$?" >> "$O/test-boids-src.log") &
wait
for v in $PLUGINS; do echo "== test_neighbors_delaunay $v: $(tail -n 3 "$O/test-$v.log" | tr '\n' ' ')"; done | tee -a "$S"
echo "== test_boids_delaunay src: $(tail -n 3 "$O/test-boids-src.log" | tr '\n' ' ')" | tee -a "$S"
echo "tests done at ${SECONDS} s" | tee -a "$S"

# 3. the issue's benchmark with src's stage, and the Verlet baseline in its own pipeline
if ((SECONDS < 120)); then
  FLIPFLOW_PLUGIN_PATH=$V/src:$B/plugins timeout 30 "$B/bin/pipeline" bench "$B/pipelines/bench-frnn.yaml" \
    --device "$DEVICE" --sizes "$SIZES" --steps 50 --warmup 10 --results "$O/results-frnn" > "$O/frnn-src.txt" 2>&1
  echo "== bench-frnn (src) rc=$? at ${SECONDS} s" | tee -a "$S"
  grep -E "^ *[0-9]|max_visited|error" "$O/frnn-src.txt" | tee -a "$S"
  timeout 25 "$B/bin/pipeline" bench "$B/pipelines/bench-frnn-verlet.yaml" --device "$DEVICE" --sizes "$SIZES" \
    --steps 30 --warmup 5 --results "$O/results-verlet" > "$O/verlet.txt" 2>&1
  echo "== bench-frnn-verlet rc=$? at ${SECONDS} s" | tee -a "$S"
  grep -E "^ *[0-9]|error" "$O/verlet.txt" | tee -a "$S"
else
  echo "== skipped (bench-frnn, verlet): ${SECONDS} s spent" | tee -a "$S"
fi

# 4. boids with src's stage
if ((SECONDS < 135)); then
  FLIPFLOW_PLUGIN_PATH=$V/src:$B/plugins timeout 40 "$B/bin/pipeline" bench "$B/pipelines/bench-boids-delaunay.yaml" \
    --device "$DEVICE" --sizes "$SIZES" --steps 15 --warmup 3 --results "$O/results-boids" > "$O/boids-src.txt" 2>&1
  echo "== boids-delaunay (src) rc=$? at ${SECONDS} s" | tee -a "$S"
  grep -E "^ *[0-9]|max_visited|substeps|error" "$O/boids-src.txt" | tee -a "$S"
else
  echo "== skipped (boids): ${SECONDS} s spent" | tee -a "$S"
fi
echo "total ${SECONDS} s" | tee -a "$S"
