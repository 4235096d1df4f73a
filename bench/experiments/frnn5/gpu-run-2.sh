#!/bin/bash
# frnn5, batch 2 (issue 17, neighbors.delaunay; branch frnn5). One H200, < 3 min. Same bundle as
# batch 1 (main d49d962 extracted as ./bundle):
#
#   BUNDLE=bundle OUT=$OUT bash gpu-carry/frnn5/run2.sh
#
# Batch 1 said: staging a block's records and rows in shared memory (bc: 0.706 ms at 2^20) and
# tiles of lanes per particle (0.95-1.29) lose to main's thread-per-particle search (0.672): the
# search is not waiting on its loads. Its PTX shows what it does instead: no shared-memory load
# at all — the queue (16 slots in shared memory that move to the list's row when full) is read
# through a generic pointer with 64-bit address arithmetic (61 generic loads, 131 add.s64, 82
# mul.wide in the kernel). sq keeps the queue's pointer fixed (a search that outgrows the 16
# slots starts again with the queue in the row): ld.shared with 32-bit offsets, 40 registers
# instead of 48 (16 bytes spilled, in the rare row path).
#   1. test_neighbors_delaunay with sq's stage plugin on CUDA (16 819 assertions);
#   2. ab2.yaml at 2^20: main, sq, bc, main2 on the same state each step, one process;
#   3. ncu (--set full, SASS source counters) of step 3's launches of main's, sq's and bc's
#      search kernels: instructions per warp, active threads per instruction (divergence), warp
#      stall reasons, pipes, L1 hit rate, per-instruction SASS counts (what to cut next);
#   5. boids at 2^20 (bench-boids-delaunay.yaml) with sq's stage, if 130 s have not passed
#      (batch 1, main's stage: neighbors.delaunay 11.7 ms a step, max_visited 33: sq runs the
#      searches past 16 twice);
#   4. neighbors.verlet rebuilt every step at 2^20 (bench-frnn-verlet.yaml; batch 1 ran out of
#      time before it), if 145 s have not passed.
# $OUT/frnn5b/summary.txt collects the lines to read; ncu's reports are beside it.
set -uo pipefail
SECONDS=0
B=$(cd "${BUNDLE:-bundle}" && pwd)
C=${CARRY:-$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)}
O=${OUT:-out}/frnn5b
V=$B/frnn5b
# For a dry run on a machine without a GPU: DEVICE=cpu SIZES=2^12 (defaults: cuda, 2^20).
DEVICE=${DEVICE:-cuda}
SIZES=${SIZES:-2^20}
mkdir -p "$O" "$V"
cp "$C"/ab2.yaml "$V/"
tar xJf "$C/so2.tar.xz" -C "$V"  # ab2/ (main, sq, bc, main2 as stages frnn_ab.<v>) and sq/
S=$O/summary.txt
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv | tee "$S"

# 1. sq's rows on CUDA
FLIPFLOW_TEST_DEVICE=$DEVICE FLIPFLOW_PLUGIN_PATH=$V/sq:$B/plugins timeout 60 "$B/bin/test_neighbors_delaunay" \
  > "$O/test-sq.log" 2>&1
echo "== test_neighbors_delaunay sq: rc=$? $(tail -n 2 "$O/test-sq.log" | tr '\n' ' ') at ${SECONDS} s" | tee -a "$S"

# 2. A/B, one process
FLIPFLOW_PLUGIN_PATH=$V/ab2 timeout 60 "$B/bin/pipeline" bench "$V/ab2.yaml" --device "$DEVICE" --sizes "$SIZES" \
  --steps 100 --warmup 20 --results "$O/results-ab2" > "$O/ab2.txt" 2>&1
echo "== ab2 rc=$? at ${SECONDS} s" | tee -a "$S"
grep -E "^[0-9]|max_visited|error" "$O/ab2.txt" | tee -a "$S"

# 3. ncu: launches 9-11 of the search kernels = step 3's main, sq, bc (4 searches a step)
NCU=$(command -v ncu || ls /usr/local/cuda/bin/ncu /opt/nvidia/nsight-compute/*/ncu 2>/dev/null | head -n 1)
echo "ncu: ${NCU:-none} $([[ -n $NCU ]] && "$NCU" --version | tail -n 1)" | tee -a "$S"
if [[ -n $NCU && $DEVICE == cuda ]]; then
  FLIPFLOW_PLUGIN_PATH=$V/ab2 timeout 75 "$NCU" --target-processes all -k regex:visited_kernel --launch-skip 8 \
    --launch-count 3 --set full --import-source no -f -o "$O/search" \
    "$B/bin/pipeline" bench "$V/ab2.yaml" --device cuda --sizes "$SIZES" --steps 1 --warmup 2 \
    --results "$O/results-ncu" > "$O/ncu-run.txt" 2>&1
  echo "== ncu rc=$? at ${SECONDS} s" | tee -a "$S"
  tail -n 5 "$O/ncu-run.txt" | tee -a "$S"
  if [[ -f $O/search.ncu-rep ]]; then
    "$NCU" -i "$O/search.ncu-rep" --page details > "$O/ncu-details.txt" 2>&1
    "$NCU" -i "$O/search.ncu-rep" --page raw --csv > "$O/ncu-raw.csv" 2>&1
    "$NCU" -i "$O/search.ncu-rep" --page source --csv --print-source sass > "$O/ncu-sass.csv" 2>&1
    echo "source page rc=$? ($(wc -l < "$O/ncu-sass.csv") lines)" | tee -a "$S"
    grep -E "visited_kernel|Duration|Executed Ipc|Issue Slots Busy|SM Busy|Warp Cycles Per Issued|Avg. Active Threads|Avg. Not Predicated|Executed Instructions  |L1/TEX Hit|Achieved Occupancy|Registers Per|Branch Efficiency|Avg. Divergent|Stall" \
      "$O/ncu-details.txt" | cut -c1-160 | tee -a "$S"
  fi
fi

# 5. boids at 2^20 with sq's stage (dense flocks fill the 16 fast slots: those searches run twice)
if ((SECONDS < 130)); then
  FLIPFLOW_PLUGIN_PATH=$V/sq:$B/plugins timeout 40 "$B/bin/pipeline" bench "$B/pipelines/bench-boids-delaunay.yaml" \
    --device "$DEVICE" --sizes "$SIZES" --steps 15 --warmup 3 --results "$O/results-boids-sq" > "$O/boids-sq.txt" 2>&1
  echo "== boids-delaunay with sq rc=$? at ${SECONDS} s" | tee -a "$S"
  grep -E "^[0-9]|max_visited|substeps|error" "$O/boids-sq.txt" | tee -a "$S"
else
  echo "== skipped (boids with sq): ${SECONDS} s spent" | tee -a "$S"
fi

# 4. Verlet at 2^20
if ((SECONDS < 145)); then
  timeout 30 "$B/bin/pipeline" bench "$B/pipelines/bench-frnn-verlet.yaml" --device "$DEVICE" --sizes "$SIZES" \
    --steps 30 --warmup 5 --results "$O/results-verlet" > "$O/verlet.txt" 2>&1
  echo "== bench-frnn-verlet rc=$? at ${SECONDS} s" | tee -a "$S"
  grep -E "^[0-9]|error" "$O/verlet.txt" | tee -a "$S"
else
  echo "== skipped (verlet): ${SECONDS} s spent" | tee -a "$S"
fi
echo "total ${SECONDS} s" | tee -a "$S"
