#!/bin/bash
# frnn7 (issue 17, neighbors.delaunay search; branch frnn7), session 18's 09:40 call. One H200,
# about 2 minutes (every step under a timeout; the whole under 175 s).
#
#   bash gpu-carry/frnn7/run.sh BUNDLE OUT      (BUNDLE: the extracted bundle of main, ABI 5)
#
# The question: which search is fastest at 2^20 against main's, in one process on the same states
# (two rounds, the second in reverse order), and does each pass test_neighbors_delaunay on CUDA.
# Variants (bench/experiments/frnn7/*.patch; README there):
#   cv     main with a converged tail: the traversal loop has one exit (no early return from the
#          member loop), the lanes meet there (__syncwarp), so compaction + sorting network + row
#          stores issue once a warp (frnn5's ncu: 4.4 times a warp at ~7 lanes, ~19 % of the
#          kernel's instructions)
#   cvj    cv + the apex skip found in the ring chunks as they are loaded (no apex_mask pass;
#          47 registers); cvi: the same without looking at the second chunk first (40 registers,
#          a few more member tests)
#   cvs, cvjs, cvis: + frnn6's ordered blocks (a block's searches ordered by last step's count)
#   fm4bs  frnn6's flat loop, four members an iteration, ordered blocks (0.435 in call 1)
#   fm4bsc fm4bs + the converged tail;  fm4bsc10: capped at 48 registers (10 blocks an SM)
#   fm4bsci fm4bsc with the blocks ordered by last step's loop iterations instead of visited
#          count (capped at 56 registers: the counter took it to 62)
#   fm4bscq fm4bsc + each queued vertex's ring start and degree packed beside its queue entry
#          (8 KB more shared memory a block), so an expansion loads its ring without the record
#   fm4bc  fm4b (no ordering) + the converged tail
# Output: $OUT/frnn7/summary.txt (the bench line: frnn_ab.<v>=ms per step; the tests; ncu).
set -uo pipefail
SECONDS=0
B=$(cd "${1:-${BUNDLE:-bundle}}" && pwd)
OUTDIR=${2:-${OUT:-out}}
C=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
O=$OUTDIR/frnn7
DEVICE=${DEVICE:-cuda}
SIZES=${SIZES:-2^20}
TESTS=${TESTS:-"fm4bsc fm4bsci fm4bscq fm4bsc10 fm4bc cv cvs cvj cvjs cvis"}
V=$B/frnn7
mkdir -p "$O" "$V"
cp "$C"/ab.yaml "$V/"
tar xJf "$C/so.tar.xz" -C "$V"
S=$O/summary.txt
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv > "$S" 2>&1
cat "$B/.flipflow-bundle" >> "$S" 2>/dev/null

FLIPFLOW_PLUGIN_PATH=$V/ab timeout 100 "$B/bin/pipeline" bench "$V/ab.yaml" --device "$DEVICE" --sizes "$SIZES" \
  --steps 40 --warmup 10 --results "$O/results-ab" > "$O/ab.txt" 2>&1
echo "== ab rc=$? at ${SECONDS} s" | tee -a "$S"
grep -E "^ *[0-9]|main/max_visited|error" "$O/ab.txt" | tee -a "$S"

left=$((160 - SECONDS))
((left > 75)) && left=75
for v in $TESTS; do
  (FLIPFLOW_TEST_DEVICE=$DEVICE FLIPFLOW_PLUGIN_PATH=$V/$v:$B/plugins timeout $left "$B/bin/test_neighbors_delaunay" \
     > "$O/test-$v.log" 2>&1; echo "rc=$?" >> "$O/test-$v.log") &
done
wait
for v in $TESTS; do echo "== test_neighbors_delaunay $v: $(tail -n 3 "$O/test-$v.log" | tr '\n' ' ')"; done | tee -a "$S"
echo "tests done at ${SECONDS} s" | tee -a "$S"

# ncu, while time is left: one launch each of main's, fm4bs's, fm4bsc's and cvjs's search and of
# main's ring gather at 2^18
# (average active threads a warp, instructions, issue slots, occupancy; per-SASS-instruction counts).
NCU=$(command -v ncu || ls /usr/local/cuda*/bin/ncu /opt/nvidia/nsight-compute/*/ncu /usr/local/NVIDIA-Nsight-Compute*/ncu 2>/dev/null | head -n 1)
echo "ncu: ${NCU:-none}" | tee -a "$S"
if [[ -n $NCU && $DEVICE == cuda ]] && ((SECONDS < 125)); then
  FLIPFLOW_PLUGIN_PATH=$V/ab timeout $((172 - SECONDS)) "$NCU" --target-processes all --kernel-name-base demangled \
    -k 'regex:frnn_ab_(main|fm4bs|fm4bsc|cvjs)::.*visited_kernel|frnn_ab_main::.*gather_kernel' \
    --launch-skip 10 --launch-count 5 \
    --section LaunchStats --section Occupancy --section SchedulerStats --section WarpStateStats \
    --section MemoryWorkloadAnalysis \
    --section InstructionStats --section SpeedOfLight --section SourceCounters -f -o "$O/search" \
    "$B/bin/pipeline" bench "$V/ab.yaml" --device cuda --sizes 2^18 --steps 1 --warmup 3 \
    --results "$O/results-ncu" > "$O/ncu-run.txt" 2>&1
  echo "== ncu rc=$? at ${SECONDS} s" | tee -a "$S"
  if [[ -f $O/search.ncu-rep ]]; then
    "$NCU" -i "$O/search.ncu-rep" --page details > "$O/ncu-details.txt" 2>&1
    "$NCU" -i "$O/search.ncu-rep" --page source --csv --print-source sass 2>&1 | xz > "$O/ncu-sass.csv.xz"
    grep -E "visited_kernel|gather_kernel|Duration|Issue Slots Busy|Avg. Active Threads|Executed Instructions  |Achieved Occupancy|Registers Per|DRAM Throughput|L2 Hit Rate|Memory Throughput" \
      "$O/ncu-details.txt" | cut -c1-140 | tee -a "$S"
  fi
else
  echo "== ncu skipped at ${SECONDS} s" | tee -a "$S"
fi
echo "total ${SECONDS} s" | tee -a "$S"
