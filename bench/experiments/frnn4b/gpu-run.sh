#!/bin/bash
# frnn4b, batch 1 (issue 17; branch frnn4b, worktree /work/wt/frnn4b). Run with a bundle of main,
# either ABI: abi3.tar.xz holds the plugins and tests built on 84b0f59 (ABI 3, bundle-head.tar.gz
# of fe5950a), abi4.tar.xz the same built on 13326de (ABI 4, after the decomp merge); the script
# unpacks the one the bundle's pipeline loads.
#
#   BUNDLE=/path/to/bundle OUT=$OUT bash /work/main/gpu-carry/frnn4b/run.sh
#
# (CARRY=<this folder> if it is not at /work/main/gpu-carry/frnn4b.) Unpacks into $BUNDLE/frnn4b/
# (the .so files and test binaries carry rpath $ORIGIN/../../lib). Under 3 minutes: each step
# after the tests is skipped once BUDGET seconds (default 165) have passed.
# Two questions:
#  A. neighbors.delaunay: does staging a block's own vertices' records and ring rows in shared
#     memory (bc16: 16 queue slots + 2 KB records + 5 KB rows = 15 KB a block; bc8: 8 queue
#     slots) make the search faster than main and than s16 (16 queue slots only, frnn4's patch)?
#     bc256: bc16 with blocks of 256 (30 KB a block). On the CPU at 2^16, 75 % of the member
#     records and 83 % of the expanded rows a search reads are its own block's of 128 (Hilbert
#     order), 84 % and 89 % of 256.
#  B. boids with neighbors.delaunay (pipelines/bench-boids-delaunay.yaml: flip with
#     on_unrepairable: substep, which now sub-steps pairs that pass each other): does it run at
#     2^20 on the GPU (it stopped at step 19 before), and at what ms per step?
#   1. tests: main's test_neighbors_delaunay with bc16 / bc8 / bc256 (CUDA: brute force, CPU == CUDA
#      rows, 10^3 hard-disk steps vs neighbors.verlet); the branch's test_delaunay_flip and
#      test_boids_delaunay (its new case: boids with Delaunay neighbours + substep follow the
#      Verlet-only run bit for bit) and main's test_delaunay_detect_inversion with the branch's
#      delaunay stages;
#   2. speed A: frnn-ab-fwd.yaml (frnn_ab.main, .s16, .bc16, .bc8, .bc256 one after another on the same
#      state every step) at 2^18 and 2^20;
#   3. speed B: bench-boids-delaunay.yaml at 2^20, 30 steps after 5 (stage ms, substeps per step);
#   4. speed A again in reverse order (frnn-ab-rev.yaml) at 2^20.
# Everything lands in $OUT/frnn4b/; summary.txt collects the lines to read.
set -uo pipefail
SECONDS=0
B=$(cd "${BUNDLE:-bundle}" && pwd)
C=${CARRY:-/work/main/gpu-carry/frnn4b}
O=${OUT:-out}/frnn4b
BUDGET=${BUDGET:-165}
V=$B/frnn4b
mkdir -p "$O" "$V"
cp "$C"/*.yaml "$V/"
S=$O/summary.txt
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv | tee "$S"
for abi in 3 4; do
  rm -rf "$V/ab" "$V/bc16" "$V/bc8" "$V/bc256" "$V/delaunay" "$V/bin"
  tar xJf "$C/abi$abi.tar.xz" -C "$V"
  FLIPFLOW_PLUGIN_PATH=$V/delaunay "$B/bin/pipeline" describe delaunay.flip > "$O/abi$abi.txt" 2>&1 && break
done
echo "plugins of ABI $abi ($(grep -c 'passed each other' "$O/abi$abi.txt") = the branch's delaunay.flip)" | tee -a "$S"
left() { ((SECONDS < BUDGET)) || { echo "== skipped ($1): ${SECONDS} s spent" | tee -a "$S"; return 1; }; }

# 1. tests, all at once
for v in bc16 bc8 bc256; do
  (FLIPFLOW_TEST_DEVICE=cuda FLIPFLOW_PLUGIN_PATH=$V/$v:$B/plugins timeout 80 "$B/bin/test_neighbors_delaunay" \
     > "$O/test-neighbors-$v.log" 2>&1; echo "rc=$?" >> "$O/test-neighbors-$v.log") &
done
(FLIPFLOW_TEST_DEVICE=cuda FLIPFLOW_PLUGIN_PATH=$V/delaunay:$B/plugins timeout 80 "$V/bin/test_delaunay_flip" \
   > "$O/test-flip.log" 2>&1; echo "rc=$?" >> "$O/test-flip.log") &
(FLIPFLOW_TEST_DEVICE=cuda FLIPFLOW_PLUGIN_PATH=$V/delaunay:$B/plugins timeout 80 "$V/bin/test_boids_delaunay" \
   > "$O/test-boids.log" 2>&1; echo "rc=$?" >> "$O/test-boids.log") &
(FLIPFLOW_TEST_DEVICE=cuda FLIPFLOW_PLUGIN_PATH=$V/delaunay:$B/plugins timeout 80 "$B/bin/test_delaunay_detect_inversion" \
   > "$O/test_delaunay_detect_inversion.log" 2>&1; echo "rc=$?" >> "$O/test_delaunay_detect_inversion.log") &
wait
for f in "$O"/test-*.log "$O"/test_*.log; do echo "== $(basename "$f"): $(tail -n 3 "$f" | tr '\n' ' ')"; done | tee -a "$S"
echo "tests done at ${SECONDS} s" | tee -a "$S"

# 2. search variants, one process (the real delaunay stages of the bundle: only the searches differ)
if left ab; then
  FLIPFLOW_PLUGIN_PATH=$V/ab timeout 75 "$B/bin/pipeline" bench "$V/frnn-ab-fwd.yaml" --device cuda --sizes 2^18,2^20 \
    --steps 100 --warmup 20 --results "$O/results" > "$O/frnn-ab-fwd.txt" 2>&1
  echo "== frnn-ab-fwd rc=$? at ${SECONDS} s" | tee -a "$S"
  grep -E "^[0-9]|max_visited" "$O/frnn-ab-fwd.txt" | tee -a "$S"
fi

# 3. boids on the maintained triangulation at 2^20 (the branch's delaunay stages)
if left boids; then
  FLIPFLOW_PLUGIN_PATH=$V/delaunay timeout 60 "$B/bin/pipeline" bench "$V/bench-boids-delaunay.yaml" --device cuda \
    --sizes 2^20 --steps 30 --warmup 5 --results "$O/results-boids" > "$O/boids.txt" 2>&1
  echo "== boids-delaunay rc=$? at ${SECONDS} s" | tee -a "$S"
  grep -E "^[0-9]|substeps|rollback|unrepairable|flip_rounds|error|failed" "$O/boids.txt" | cut -c1-400 | tee -a "$S"
fi

# 4. search variants, reverse order, 2^20
if left ab-rev; then
  FLIPFLOW_PLUGIN_PATH=$V/ab timeout 60 "$B/bin/pipeline" bench "$V/frnn-ab-rev.yaml" --device cuda --sizes 2^20 \
    --steps 100 --warmup 20 --results "$O/results" > "$O/frnn-ab-rev.txt" 2>&1
  echo "== frnn-ab-rev rc=$? at ${SECONDS} s" | tee -a "$S"
  grep -E "^[0-9]|max_visited" "$O/frnn-ab-rev.txt" | tee -a "$S"
fi
echo "total ${SECONDS} s" | tee -a "$S"
