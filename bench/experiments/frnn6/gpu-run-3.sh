#!/bin/bash
# frnn6, final GPU call (issue 17, neighbors.delaunay search; branch frnn6). One H200, < 60 s.
#
#   bash gpu-carry/frnn6/gpu-run-3.sh BUNDLE OUT      (BUNDLE: the extracted bundle of main, ABI 5)
#
# Call 2 of session 17 (gpu-run.sh, fifteen searches in one process at 2^20) said: main 0.577 ms;
# the queue scanned newest first (sqb, now the branch's source `src`) 0.530; the flat loop with
# two members an iteration (fm2b) 0.525; ordering a block's searches by last step's visited count
# took 9-10 % off the flat loops that had it (fmrbs vs fmrb, fmras vs fmra). This call combines:
#   src    0f44f88 (main + newest-first scan)
#   sqbs   src + the block ordering
#   sqbl   src + each ring chunk's four member records loaded together before the member tests
#          (four loads in flight, as fm4b does in the flat loop; 48 registers, no spill)
#   sqbls  sqbl + the block ordering
#   sqblp  sqbl + the next queued vertex's record loaded before the current ring is tested
#          (56 registers);  sqblps: + the block ordering
#   fm2b   the flat loop, two members an iteration (repeat)
#   fm2bs  fm2b + the block ordering
#   fm4b   the flat loop, up to four members an iteration (four record loads in flight; 56 regs)
#   fm4bs  fm4b + the block ordering
#   fm4bp  fm4b + the next queued vertex's record loaded when the ring's last members are picked
#          (63 registers);  fm4bps: + the block ordering
#   main, main2: 75cd2a8, first and last; neighbors.verlet rebuilt every step, same process.
# One pipeline bench of ab3.yaml at 2^20 (40 steps after 10), nothing else (the tests of these
# variants ran on the CPU; sqb, fm2b and the ordering (fmrbs, fmras) passed test_neighbors_delaunay
# on CUDA in call 2). $OUT/frnn6c/summary.txt has the line to read.
set -uo pipefail
SECONDS=0
B=$(cd "${1:-${BUNDLE:-bundle}}" && pwd)
OUTDIR=${2:-${OUT:-out}}
C=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
O=$OUTDIR/frnn6c
DEVICE=${DEVICE:-cuda}
SIZES=${SIZES:-2^20}
V=$B/frnn6c
mkdir -p "$O" "$V"
cp "$C"/ab3.yaml "$V/"
tar xJf "$C/so3.tar.xz" -C "$V"  # ab/ (built on 75cd2a8, ABI 5) and ab6/ (the same sources on graph4 7ad9dc1, ABI 6)
S=$O/summary.txt
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv > "$S" 2>&1
# The bundle's plugin ABI: 5 (main before graph4) takes ab/, 6 (graph4 merged) ab6/.
if ! FLIPFLOW_PLUGIN_PATH=$V/ab "$B/bin/pipeline" stages > "$O/abi.txt" 2>&1; then
  if grep -q "this flipflow has version 6" "$O/abi.txt"; then
    rm -rf "$V/ab" && mv "$V/ab6" "$V/ab"
    echo "bundle of ABI 6: ab6/ (built on graph4 7ad9dc1)" | tee -a "$S"
  else
    tail -n 3 "$O/abi.txt" | tee -a "$S"
  fi
fi
FLIPFLOW_PLUGIN_PATH=$V/ab timeout 55 "$B/bin/pipeline" bench "$V/ab3.yaml" --device "$DEVICE" --sizes "$SIZES" \
  --steps 40 --warmup 10 --results "$O/results-ab3" > "$O/ab3.txt" 2>&1
echo "== ab3 rc=$? at ${SECONDS} s" | tee -a "$S"
grep -E "^ *[0-9]|error" "$O/ab3.txt" | tee -a "$S"
