#!/bin/bash
# frnn7 (issue 17, neighbors.delaunay search; branch frnn7), second batch. One H200, about 2
# minutes (every part under its own timeout, the whole under 175 s).
#
#   bash gpu-carry/frnn7b/run2.sh BUNDLE OUT      (BUNDLE: the extracted bundle of main, ABI 5)
#
# Call 3 (run.sh) made fm4bc the branch's source (`src`, ce882c4: 0.372 ms at 2^20 against main's
# 0.523). Its ncu (2^18): the queue scans still run with ~2 lanes of 32 (~11 % of the
# instructions), and each expansion waits for its record before it can load its ring. Variants on
# src (bench/experiments/frnn7/<v>.patch):
#   m     one merged scan of the queue an iteration for all (up to four) members the filter lets
#         through, instead of one loop a member (64 registers)
#   m9    m capped at 56 registers (9 blocks an SM, as src)
#   q     each queued vertex's ring start and degree packed beside its entry in shared memory
#         (8 KB more a block), so an expansion loads its ring without its record first
#   mq9   m + q, 56 registers
# Question: does any beat src at 2^20 (one process, two rounds, main = main's old search first
# and last); do they and src pass test_neighbors_delaunay and test_boids_delaunay on CUDA.
# Output: $OUT/frnn7b/summary.txt.
set -uo pipefail
SECONDS=0
B=$(cd "${1:-${BUNDLE:-bundle}}" && pwd)
OUTDIR=${2:-${OUT:-out}}
C=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
O=$OUTDIR/frnn7b
DEVICE=${DEVICE:-cuda}
SIZES=${SIZES:-2^20}
TESTS=${TESTS:-"src m m9 q mq9"}
V=$B/frnn7b
mkdir -p "$O" "$V"
cp "$C"/ab2.yaml "$V/"
tar xJf "$C/so.tar.xz" -C "$V"
S=$O/summary.txt
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv > "$S" 2>&1
cat "$B/.flipflow-bundle" >> "$S" 2>/dev/null

FLIPFLOW_PLUGIN_PATH=$V/ab timeout 90 "$B/bin/pipeline" bench "$V/ab2.yaml" --device "$DEVICE" --sizes "$SIZES" \
  --steps 40 --warmup 10 --results "$O/results-ab" > "$O/ab.txt" 2>&1
echo "== ab rc=$? at ${SECONDS} s" | tee -a "$S"
grep -E "^ *[0-9]|main/max_visited|error" "$O/ab.txt" | tee -a "$S"

left=$((150 - SECONDS))
((left > 75)) && left=75
for v in $TESTS; do
  for t in test_neighbors_delaunay test_boids_delaunay; do
    (FLIPFLOW_TEST_DEVICE=$DEVICE FLIPFLOW_PLUGIN_PATH=$V/$v:$B/plugins timeout $left "$B/bin/$t" \
       > "$O/$t-$v.log" 2>&1; echo "rc=$?" >> "$O/$t-$v.log") &
  done
done
wait
for v in $TESTS; do
  for t in test_neighbors_delaunay test_boids_delaunay; do
    echo "== $t $v: $(tail -n 3 "$O/$t-$v.log" | tr '\n' ' ')"
  done
done | tee -a "$S"
echo "tests done at ${SECONDS} s" | tee -a "$S"

# ncu, while time is left: one launch each of src's, m9's, q's and mq9's search and of main's ring
# gather at 2^18.
NCU=$(command -v ncu || ls /usr/local/cuda*/bin/ncu /opt/nvidia/nsight-compute/*/ncu 2>/dev/null | head -n 1)
echo "ncu: ${NCU:-none}" | tee -a "$S"
if [[ -n $NCU && $DEVICE == cuda ]] && ((SECONDS < 130)); then
  FLIPFLOW_PLUGIN_PATH=$V/ab timeout $((172 - SECONDS)) "$NCU" --target-processes all --kernel-name-base demangled \
    -k 'regex:frnn_ab_(src|m9|q|mq9)::.*visited_kernel|frnn_ab_main::.*gather_kernel' \
    --launch-skip 10 --launch-count 5 \
    --section LaunchStats --section Occupancy --section SchedulerStats --section WarpStateStats \
    --section MemoryWorkloadAnalysis --section InstructionStats --section SpeedOfLight --section SourceCounters \
    -f -o "$O/search" "$B/bin/pipeline" bench "$V/ab2.yaml" --device cuda --sizes 2^18 --steps 1 --warmup 3 \
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
