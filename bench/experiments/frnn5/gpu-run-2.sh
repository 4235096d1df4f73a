#!/bin/bash
# frnn5, batch 2 (issue 17, neighbors.delaunay; branch frnn5). One H200, < 3 min. Same bundle as
# batch 1 (main d49d962 extracted as ./bundle):
#
#   BUNDLE=bundle OUT=$OUT bash gpu-carry/frnn5/run2.sh
#
# Batch 1 said: staging a block's records and rows in shared memory (bc: 0.706 ms at 2^20) and
# tiles of lanes per particle (0.95-1.29) lose to main's thread-per-particle search (0.672), so the
# search is not waiting on its loads; but ~160 instructions a particle more (bc's range tests
# and selects) cost 5 %, which, if instructions were the limit, puts the search at ~3 000
# instructions a particle: at the H200's issue rate that is ~0.1 ms, not 0.67. Which is it?
#   1. ncu (--set full, SASS-level source counters) of one launch each of main's and bc's search
#      kernels at 2^20 (ncu-ab.yaml: both stages on the same state): instructions executed per
#      warp, threads active per instruction (divergence), warp stall reasons, pipe utilisation,
#      L1 hit rate (bc's shared memory shrinks L1), and the per-instruction SASS counts;
#   2. neighbors.verlet rebuilt every step at 2^20 (bench-frnn-verlet.yaml; batch 1 ran out of
#      time before it), the number maintenance + search has to beat.
# $OUT/frnn5b/summary.txt collects the lines to read; ncu's reports are beside it.
set -uo pipefail
SECONDS=0
B=$(cd "${BUNDLE:-bundle}" && pwd)
C=${CARRY:-$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)}
O=${OUT:-out}/frnn5b
V=$B/frnn5
mkdir -p "$O" "$V"
cp "$C"/*.yaml "$V/"
tar xJf "$C/so.tar.xz" -C "$V"
S=$O/summary.txt
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv | tee "$S"

# 2 first (short): Verlet at 2^20
timeout 45 "$B/bin/pipeline" bench "$B/pipelines/bench-frnn-verlet.yaml" --device cuda --sizes 2^20 \
  --steps 30 --warmup 5 --results "$O/results-verlet" > "$O/verlet.txt" 2>&1
echo "== bench-frnn-verlet rc=$? at ${SECONDS} s" | tee -a "$S"
grep -E "^[0-9]|error" "$O/verlet.txt" | tee -a "$S"

# 1. ncu: the 3rd step's launches of both searches (launches 5 and 6: main, bc, main, bc, ...)
NCU=$(command -v ncu || ls /usr/local/cuda/bin/ncu /opt/nvidia/nsight-compute/*/ncu 2>/dev/null | head -n 1)
echo "ncu: ${NCU:-none} $([[ -n $NCU ]] && "$NCU" --version | tail -n 1)" | tee -a "$S"
if [[ -n $NCU ]]; then
  FLIPFLOW_PLUGIN_PATH=$V/ab timeout 120 "$NCU" --target-processes all -k regex:visited_kernel --launch-skip 4 --launch-count 2 \
    --set full --import-source no -f -o "$O/search" \
    "$B/bin/pipeline" bench "$V/ncu-ab.yaml" --device cuda --sizes 2^20 --steps 1 --warmup 2 \
    --results "$O/results-ncu" > "$O/ncu-run.txt" 2>&1
  echo "== ncu rc=$? at ${SECONDS} s" | tee -a "$S"
  tail -n 5 "$O/ncu-run.txt" | tee -a "$S"
  if [[ -f $O/search.ncu-rep ]]; then
    "$NCU" -i "$O/search.ncu-rep" --page details > "$O/ncu-details.txt" 2>&1
    "$NCU" -i "$O/search.ncu-rep" --page raw --csv > "$O/ncu-raw.csv" 2>&1
    "$NCU" -i "$O/search.ncu-rep" --page source --csv --print-source sass > "$O/ncu-sass.csv" 2>&1
    echo "source page rc=$? ($(wc -l < "$O/ncu-sass.csv") lines)" | tee -a "$S"
    grep -E "visited_kernel|Duration|Executed Ipc|Issue Slots Busy|SM Busy|Warp Cycles Per Issued|Avg. Active Threads|Avg. Not Predicated|Executed Instructions |L1/TEX Hit|L2 Hit|Achieved Occupancy|Theoretical Occupancy|Registers Per|Branch Efficiency|Avg. Divergent" \
      "$O/ncu-details.txt" | cut -c1-160 | tee -a "$S"
  fi
fi
echo "total ${SECONDS} s" | tee -a "$S"
