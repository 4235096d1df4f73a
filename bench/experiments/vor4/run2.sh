#!/bin/bash
# vor4's final GPU check (issue 18: voronoi.geometry at 2^20 <= 0.1 ms per call on an H100), about
# 50 s on one H200:   bash run2.sh BUNDLE OUT      (OUT/vor4-final/summary.txt is what to read)
# The head of branch vor4 (7a5d922: kernel.h with explicit fmas, circumcentres as bisector
# parameters, a reciprocal per circumcentre; its stage plugin is head/):
#   1. the branch's test_voronoi_geometry (CGAL to 1e-10, lattices, CPU == CUDA bit for bit with
#      the default outputs and with faces + circumcentres) and test_voronoi_mirror, in parallel
#      (~7 s), then
#   2. the issue's measurement: plain `pipeline bench pipelines/bench-voronoi.yaml --device cuda
#      --sizes 1048576 --steps 100 --warmup 20` with the head's plugin (main's is known from the
#      same bundle: 0.103-0.107; call 2's one-process A/B: main 0.105 / 0.103, this kernel 0.090).
# DEV=cpu N=65536: a dry run without a GPU.
set -uo pipefail
SECONDS=0
DEV=${DEV:-cuda}
N=${N:-1048576}
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
B=$(cd "${1:-${BUNDLE:-bundle}}" && pwd)
O=${2:-${OUT:-out}}/vor4-final
mkdir -p "$O"
V=$B/vor4
rm -rf "$V"
mkdir -p "$V"
cp -r "$here/head" "$here/tests" "$V/"
S=$O/summary.txt
{ nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv 2>&1; cat "$B/.flipflow-bundle" 2>/dev/null; echo; } > "$S"
for t in geometry mirror; do
  (FLIPFLOW_PLUGIN_PATH=$V/head:$B/plugins FLIPFLOW_TEST_DEVICE=$DEV timeout 40 "$V/tests/test_voronoi_$t" \
     > "$O/test-$t.log" 2>&1; echo "rc=$?" >> "$O/test-$t.log") &
done
wait  # the tests first: the bench's timed steps alone on the GPU
FLIPFLOW_PLUGIN_PATH=$V/head:$B/plugins timeout 55 "$B/bin/pipeline" bench "$B/pipelines/bench-voronoi.yaml" \
  --device "$DEV" --sizes "$N" --steps 100 --warmup 20 --results "$O/plain-results" > "$O/plain-head.txt" 2>&1
rc=$?
for t in geometry mirror; do
  echo "== test $t: $(grep -E 'FAILED|All tests passed|test cases|rc=' "$O/test-$t.log" | sort -u | head -6 | tr '\n' ' ')"
done >> "$S"
echo "== plain bench-voronoi, head, rc=$rc: $(grep -E '^[0-9]' "$O/plain-head.txt" | head -1)" >> "$S"
rm -rf "$O/plain-results"
echo "total: ${SECONDS} s" >> "$S"
cat "$S"
