#!/bin/bash
# frnn5 (issue 17, neighbors.delaunay speed; branch frnn5, worktree /work/wt/frnn5). One H200, < 3 min.
# Run from the repository root with the bundle of main d49d962 extracted as ./bundle:
#
#   tar -xzf gpu-carry/bundle-main.tar.gz   # -> ./bundle
#   BUNDLE=bundle OUT=$OUT bash gpu-carry/frnn5/run.sh
#
# Question A: does staging a block's own vertices' records and ring rows in shared memory make the
# search (main: 0.666 ms at 2^20 on an H200, instruction/latency bound) faster? Variants, each the
# whole change against d49d962's stages/neighbors/delaunay/ (bench/experiments/frnn5/<v>.patch):
#   bc     the search's block of 128 stages its vertices' 16-byte records (2 KB) and their ring
#          rows (the gather wrote them contiguously, 5 KB) in shared memory; other vertices' from
#          the arrays (frnn4b's bc16, never run, ported to main's search: apex skip, network sort)
#   bcx    bc + the block's current positions in shared memory too (the accept test's loads)
#   bcxe   bcx + the expansion radius (two double square roots) once per block, not per thread
#   bcxna  bcx without the parent-apex skip (does it still pay when the loads it saves are cheap?)
#   bcxnf  bcx without the 128-bit hash filter (the parent-apex skip left few queue scans)
#   bcxnn  bcx with neither the apex skip nor the filter (40 registers instead of 48: 12 blocks
#          an SM instead of 10; bcxna and bcxnf are at 40 too)
#   bcx12  bcx with __launch_bounds__(128, 12): 40 registers, 24 bytes spilled
#   bc8    bc with 8 queue slots in shared memory instead of 16
#   bc256  bc with blocks of 256 (gather and search)
#   tbx    bcx's staging + a tile of 8 lanes per particle (frnn3's tile8pf: 0.090 vs 0.120 ms at
#          2^16, lost at 2^20 where its loads went to L2): blocks of 1024 threads search the
#          gather's 128 vertices; ring members over the lanes, visited set a shared-memory hash
#          set, queue by ballot, rows placed by rank. 56 registers: one block an SM
#   tbx2   tbx with __launch_bounds__(1024, 2): 32 registers (76 bytes spilled), two blocks an SM
#   tb4x   tbx with tiles of 4 lanes (blocks of 512): 56 registers, two blocks an SM
#   main, main2: main's stage, first and last in the step (the order's effect)
# Question B: boids at 2^20 on the GPU with neighbors.delaunay: ms per step by stage
# (pipelines/bench-boids-delaunay.yaml of the bundle, main's stages).
# Question C: neighbors.verlet rebuilt every step at r = 2 sigma on the same GPU (bench-frnn-verlet.yaml),
# against which maintenance (detect_inversion + flip + lawson) + search competes.
# Steps:
#   1. test_neighbors_delaunay (bundle's binary) with each variant's stage plugin, on CUDA (brute
#      force rows, CPU == CUDA rows, 10^3 hard-disk steps against neighbors.verlet), all at once;
#   2. frnn-ab.yaml at 2^20: all fourteen searches on the same state each step, one process;
#   3. bench-boids-delaunay.yaml at 2^20; 4. bench-frnn-verlet.yaml at 2^20.
# Step 3 is skipped after 130 s, step 4 after 140 s (worst case 178 s). $OUT/frnn5/summary.txt
# collects the lines to read.
set -uo pipefail
SECONDS=0
B=$(cd "${BUNDLE:-bundle}" && pwd)
C=${CARRY:-$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)}
O=${OUT:-out}/frnn5
# For a dry run on a machine without a GPU: DEVICE=cpu SIZES=2^12 (defaults: cuda, 2^20).
DEVICE=${DEVICE:-cuda}
SIZES=${SIZES:-2^20}
V=$B/frnn5
mkdir -p "$O" "$V"
cp "$C"/*.yaml "$V/"
tar xJf "$C/so.tar.xz" -C "$V"  # ab/ and one folder per variant (.so with rpath $ORIGIN/../../lib)
S=$O/summary.txt
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv | tee "$S"
left() { ((SECONDS < ${2:-$BUDGET})) || { echo "== skipped ($1): ${SECONDS} s spent" | tee -a "$S"; return 1; }; }

# 1. tests, all at once
VARIANTS="bc bcx bcxe bcxna bcxnf bcxnn bcx12 bc8 bc256 tbx tbx2 tb4x"
for v in $VARIANTS; do
  (FLIPFLOW_TEST_DEVICE=$DEVICE FLIPFLOW_PLUGIN_PATH=$V/$v:$B/plugins timeout 75 "$B/bin/test_neighbors_delaunay" \
     > "$O/test-$v.log" 2>&1; echo "rc=$?" >> "$O/test-$v.log") &
done
wait
for v in $VARIANTS; do echo "== test_neighbors_delaunay $v: $(tail -n 3 "$O/test-$v.log" | tr '\n' ' ')"; done | tee -a "$S"
echo "tests done at ${SECONDS} s" | tee -a "$S"

# 2. the searches, one process, same state each step
FLIPFLOW_PLUGIN_PATH=$V/ab timeout 70 "$B/bin/pipeline" bench "$V/frnn-ab.yaml" --device "$DEVICE" --sizes "$SIZES" \
  --steps 100 --warmup 20 --results "$O/results-ab" > "$O/frnn-ab.txt" 2>&1
echo "== frnn-ab rc=$? at ${SECONDS} s" | tee -a "$S"
grep -E "^[0-9]|max_visited|error" "$O/frnn-ab.txt" | tee -a "$S"

# 3. boids with Delaunay neighbours at 2^20 (main's stages)
if left boids 130; then
  timeout 45 "$B/bin/pipeline" bench "$B/pipelines/bench-boids-delaunay.yaml" --device "$DEVICE" --sizes "$SIZES" \
    --steps 15 --warmup 3 --results "$O/results-boids" > "$O/boids.txt" 2>&1
  echo "== boids-delaunay rc=$? at ${SECONDS} s" | tee -a "$S"
  grep -E "^[0-9]|substeps|rollback|unrepairable|error|failed" "$O/boids.txt" | tee -a "$S"
fi

# 4. neighbors.verlet rebuilt every step, same GPU
if left verlet 140; then
  timeout 38 "$B/bin/pipeline" bench "$B/pipelines/bench-frnn-verlet.yaml" --device "$DEVICE" --sizes "$SIZES" \
    --steps 30 --warmup 5 --results "$O/results-verlet" > "$O/verlet.txt" 2>&1
  echo "== bench-frnn-verlet rc=$? at ${SECONDS} s" | tee -a "$S"
  grep -E "^[0-9]|error" "$O/verlet.txt" | tee -a "$S"
fi
echo "total ${SECONDS} s" | tee -a "$S"
