#!/bin/bash
# frnn4, batch 2 (issue 17, neighbors.delaunay; branch frnn4, worktree /work/wt/frnn4). Under 90 s.
# Run from /work/main's root with a bundle of main's HEAD (ABI 3):
#
#   BUNDLE=/path/to/bundle OUT=$OUT bash /work/main/gpu-carry/frnn4/run.sh
#
# Batch 1 said: the search is not L1-bound (s16 0.737 vs main 0.759 ms at 2^20; ncu: SM 67 %,
# memory 40 %, L2 27 %), and sorting the rows costs ~0.09 ms (unsorted 0.647). So batch 2 cuts
# instructions, keeping the rows exact:
#   sx    s16 + streaming stores + clockwise gather (batch 1: 0.732)
#   sxa   sx + ap: a queued vertex's expansion skips its parent and the parent's two ring
#         neighbours, tested by the parent's expansion (CPU: queue scans 74 -> 17 a particle;
#         CPU 2^14 A/B: 3.53-3.66 ms vs main 4.53-4.63)
#   sxc   sx + ap3: skips every slot next to p or an expanded vertex (record loads 29.6 -> 21.8)
#   sxs, sxas, sxcs   sx, sxa, sxc with rows of <= 16 sorted by a 63-comparator network in
#         registers instead of the insertion sort
#   main, main2   main's stage first and last in the step (the order's effect)
#   1. frnn-ab2.yaml at 2^20 (all eight on the same state each step): stage ms per step;
#   2. test_neighbors_delaunay on the GPU with sxas's and sxcs's stage plugins.
set -uo pipefail
SECONDS=0
B=$(cd "${BUNDLE:-bundle}" && pwd)
C=${CARRY:-/work/main/gpu-carry/frnn4}
O=${OUT:-out}/frnn4
V=$B/frnn4
mkdir -p "$O" "$V"
cp -r "$C"/. "$V/"
S=$O/summary.txt
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv | tee "$S"
FLIPFLOW_PLUGIN_PATH=$V/ab timeout 60 "$B/bin/pipeline" bench "$V/frnn-ab2.yaml" --device cuda --sizes 2^20 \
  --steps 100 --warmup 20 --results "$O/results" > "$O/frnn-ab2.txt" 2>&1
echo "== frnn-ab2 rc=$? at ${SECONDS} s" | tee -a "$S"
grep -E "^[0-9]|max_visited" "$O/frnn-ab2.txt" | tee -a "$S"
for v in sxas sxcs; do
  (FLIPFLOW_TEST_DEVICE=cuda FLIPFLOW_PLUGIN_PATH=$V/$v:$B/plugins timeout 45 "$B/bin/test_neighbors_delaunay" \
     > "$O/test-$v.log" 2>&1; echo "rc=$?" >> "$O/test-$v.log") &
done
wait
for v in sxas sxcs; do echo "== test_neighbors_delaunay $v: $(tail -n 3 "$O/test-$v.log" | tr '\n' ' ')"; done | tee -a "$S"
echo "total ${SECONDS} s" | tee -a "$S"
