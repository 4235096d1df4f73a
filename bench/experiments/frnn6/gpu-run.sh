#!/bin/bash
# frnn6, GPU call 1 (issue 17, neighbors.delaunay search speed; branch frnn6). One H200, < 3 min.
#
#   bash gpu-carry/frnn6/gpu-run.sh BUNDLE OUT      (BUNDLE: the extracted bundle of main, ABI 5)
#
# Question: does a flat search loop (one ring member per iteration, so the lanes of a warp stay
# converged) beat main's nested loops (ncu, session 16: issue bound, ~10 of 32 lanes active, 60 %
# of the instructions in the member loop)? Variants, each the whole change against main 75cd2a8's
# stages/neighbors/delaunay/ (bench/experiments/frnn6/<v>.patch):
#   fm     flat loop: the row being expanded held 8 slots at a time in registers, a bit mask of
#          the slots still to test (apex skip applied by compares, not a scan); each iteration
#          takes the lowest bit, loads that member's record (before the visited test) and tests
#          it; an empty mask loads the next queued vertex's row. 48 registers. CPU counters
#          (count-fm.patch, 2^16): 30.9 iterations a lane, 37.5 a warp (82 % of lanes busy)
#   *b     the queue scanned newest first when the filter says "maybe seen" (CPU counters: 4.9
#          scan steps a particle instead of 17; summed over a warp's iterations, the longest
#          lane's scan: 85 steps instead of 192)
#   fmb    fm + b;  sqb: main + b (the scan order alone, on main's loops)
#   fm2b   fm + b, two members an iteration (both records loaded, then tested in turn)
#   fmnb   fm + b without the parent-apex skip (cheaper refill, more iterations). 40 registers
#   fmb12  fmb with __launch_bounds__(128, 12): 40 registers, some bytes spilled
#   fmr    fm + the queue keeps each entry's ring start and degree (24 KB shared a block) and the
#          next queued vertex's row is loaded as soon as it is queued (in flight while the
#          current ring's members are tested). 64 registers
#   fmrb   fmr + b;  fmrb10: fmrb with __launch_bounds__(128, 10): 48 registers, 40 B spilled
#   fmr2b  fmrb with two members an iteration (as fm2b). 64 registers
#   fmrbs  fmrb + a block's searches ordered by each particle's visited count of the last step
#          (counting sort in shared memory; CPU counters: a warp's iterations 37.5 -> 33.2)
#   fmra   fmrb with one row buffer: when a lane picks the last held member, the next ring (or
#          the next 8 slots) is loaded into the same registers at once (no copy, no `next`):
#          51 registers instead of 64 (9 blocks an SM instead of 8)
#   fmras  fmra + fmrbs's ordering
#   main, main2: main's stage, first and last of the searches (the order's effect)
# Steps:
#   1. frnn-ab.yaml at 2^20: the fifteen searches and neighbors.verlet rebuilt every step at r = 2σ
#      (the baseline, same process, same state), 100 steps after 20;
#   2. test_neighbors_delaunay (the bundle's binary) with each variant's stage plugin on CUDA
#      (brute-force rows, CPU == CUDA rows, 10^3 hard-disk steps against neighbors.verlet), at once;
#   3. ncu (--set full) of step 3's launches of the first three search kernels (main fmb fmrb),
#      if < 110 s have passed; details and the per-SASS-instruction source page (xz).
# $OUT/frnn6/summary.txt collects the lines to read.
set -uo pipefail
SECONDS=0
B=$(cd "${1:-${BUNDLE:-bundle}}" && pwd)
OUTDIR=${2:-${OUT:-out}}
C=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
O=$OUTDIR/frnn6
# For a dry run on a machine without a GPU: DEVICE=cpu SIZES=2^12 (defaults: cuda, 2^20).
DEVICE=${DEVICE:-cuda}
SIZES=${SIZES:-2^20}
V=$B/frnn6
mkdir -p "$O" "$V"
cp "$C"/frnn-ab.yaml "$V/"
tar xJf "$C/so.tar.xz" -C "$V"  # ab/ (all variants as stages frnn_ab.<v>) and one folder per variant
S=$O/summary.txt
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv > "$S" 2>&1
cat "$S"

# 1. the searches and Verlet, one process, same state each step
FLIPFLOW_PLUGIN_PATH=$V/ab timeout 75 "$B/bin/pipeline" bench "$V/frnn-ab.yaml" --device "$DEVICE" --sizes "$SIZES" \
  --steps 100 --warmup 20 --results "$O/results-ab" > "$O/frnn-ab.txt" 2>&1
echo "== frnn-ab rc=$? at ${SECONDS} s" | tee -a "$S"
grep -E "^ *[0-9]|max_visited|error" "$O/frnn-ab.txt" | tee -a "$S"

# 2. tests, all at once (after the bench, so they do not share its GPU)
VARIANTS="fmb fmrb fm sqb fm2b fmnb fmb12 fmr fmrb10 fmr2b fmrbs fmra fmras"
for v in $VARIANTS; do
  (FLIPFLOW_TEST_DEVICE=$DEVICE FLIPFLOW_PLUGIN_PATH=$V/$v:$B/plugins timeout 75 "$B/bin/test_neighbors_delaunay" \
     > "$O/test-$v.log" 2>&1; echo "rc=$?" >> "$O/test-$v.log") &
done
wait
for v in $VARIANTS; do echo "== test_neighbors_delaunay $v: $(tail -n 3 "$O/test-$v.log" | tr '\n' ' ')"; done | tee -a "$S"
echo "tests done at ${SECONDS} s" | tee -a "$S"

# 3. ncu: launches 31-45 are step 3's fifteen searches (frnn-ab.yaml's order: main fmb fmrb ...);
#    the first three of them
NCU=$(command -v ncu || ls /usr/local/cuda/bin/ncu /opt/nvidia/nsight-compute/*/ncu 2>/dev/null | head -n 1)
echo "ncu: ${NCU:-none}" | tee -a "$S"
if [[ -n $NCU && $DEVICE == cuda ]] && ((SECONDS < 110)); then
  FLIPFLOW_PLUGIN_PATH=$V/ab timeout $((160 - SECONDS)) "$NCU" --target-processes all -k regex:visited_kernel \
    --launch-skip 30 --launch-count 3 --set full --import-source no -f -o "$O/search" \
    "$B/bin/pipeline" bench "$V/frnn-ab.yaml" --device cuda --sizes "$SIZES" --steps 1 --warmup 2 \
    --results "$O/results-ncu" > "$O/ncu-run.txt" 2>&1
  echo "== ncu rc=$? at ${SECONDS} s" | tee -a "$S"
  if [[ -f $O/search.ncu-rep ]]; then
    "$NCU" -i "$O/search.ncu-rep" --page details > "$O/ncu-details.txt" 2>&1
    "$NCU" -i "$O/search.ncu-rep" --page source --csv --print-source sass 2>&1 | xz > "$O/ncu-sass.csv.xz"
    grep -E "visited_kernel|Duration|Issue Slots Busy|Warp Cycles Per Issued|Avg. Active Threads|Avg. Not Predicated|Executed Instructions  |L1/TEX Hit|Achieved Occupancy|Registers Per" \
      "$O/ncu-details.txt" | cut -c1-140 | tee -a "$S"
  fi
else
  echo "== ncu skipped at ${SECONDS} s" | tee -a "$S"
fi
echo "total ${SECONDS} s" | tee -a "$S"
