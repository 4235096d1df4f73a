#!/bin/bash
# vor4 (issue 18: voronoi.geometry at 2^20 <= 0.1 ms per call on an H100; branch vor4, worktree
# /work/wt/vor4). Under 3 minutes on one H200:   bash run.sh BUNDLE OUT
# BUNDLE: the lead's bundle of main (ABI 5); OUT: a folder for the logs (OUT/vor4/summary.txt is
# what to read). DEV=cpu N=65536: a dry run without a GPU.
#
# The variants, all on main 75cd2a8 (stages/voronoi/geometry/kernel.h only; CPU == CUDA bits kept by
# writing multiply-adds as std::fma / fma, correctly rounded on both; the bits change vs main):
#   fmat     branch vor4's head 8a7e4fa (the candidate; its plugin is head/): fmas; |d|^2 once per far
#            end; each circumcentre as its two parameters t on the bisectors of its sides from v
#            (o = d/2 + t d_perp), a face's signed length (t_L - t_R)|d|, 4 x its triangle's area
#            (t_L - t_R)|d|^2; one reciprocal for the centroid. ptxas 64 registers, 8 B spilled
#   fma      d1d6b1c: fmas, |d|^2 once, a face's length +-|o_L - o_R|, shoelace sums (32 B spilled)
#   fmaonly  main's formulas with the fmas only (bench/experiments/vor4/fmaonly.patch on main)
#   fmat3    fmat at 3 blocks/SM instead of 4 (bench/experiments/vor4/fma3.patch)
#   fmatr    fmat with 0.5 * (1.0 / D) for 0.5 / D (the same bits; rcp instead of div, fmatr.patch)
#   fmatc7   fmat with a fan cache of 7 far ends instead of 12 (7 KB of shared memory a block
#            instead of 12: a larger L1 carve-out; longer fans walk again; fmatc7.patch)
# Steps:
#   1. bits: the branch's test_voronoi_geometry (CGAL to 1e-10, lattices, CPU == CUDA bit for bit
#      with the default outputs and with faces + circumcentres, fans of 7-13 and 40 sides) and
#      test_voronoi_mirror with the head's stage plugin first on the plugin path; also the
#      bundle's own test_voronoi_geometry against it. In parallel: bits.txt
#   2. one process, the same states: bench-voronoi at 2^20 (100 steps after 20) with main, fmat,
#      fma, fmaonly, fmat3, fmatr, fmatc7, main2, fmat2 as stages vor_ab.<v> one after another each step (plugin
#      vor_ab, tools/bench/make_ab_plugin.sh voronoi.geometry; built with vor3's copy of it): ms per call of each: ab.txt
#   3. plain bench-voronoi at 2^20 (the issue's measurement: voronoi.geometry right after Lawson),
#      main's plugin and the head's interleaved, main head main head ... (up to 3 pairs, a pair
#      started only while it can end before 170 s): plain-<k>-<v>.txt
set -uo pipefail
SECONDS=0
DEV=${DEV:-cuda}
N=${N:-1048576}
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
B=$(cd "${1:-${BUNDLE:-bundle}}" && pwd)
O=${2:-${OUT:-out}}/vor4
mkdir -p "$O"
V=$B/vor4
rm -rf "$V"
mkdir -p "$V"
cp -r "$here"/. "$V/"
sed -i "s/N: 1048576/N: $N/" "$V/vor-ab.yaml"
S=$O/summary.txt
{ nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv 2>&1; cat "$B/.flipflow-bundle" 2>/dev/null; echo; } | tee "$S"
# 1. bits
run_test() {  # name binary
  (FLIPFLOW_PLUGIN_PATH=$V/head:$B/plugins FLIPFLOW_TEST_DEVICE=$DEV timeout 80 "$2" > "$O/test-$1.log" 2>&1
   echo "rc=$?" >> "$O/test-$1.log") &
}
run_test geometry "$V/tests/test_voronoi_geometry"
run_test mirror "$V/tests/test_voronoi_mirror"
run_test geometry-bundle-binary "$B/bin/test_voronoi_geometry"
wait
for t in geometry mirror geometry-bundle-binary; do
  echo "== test $t: $(grep -E 'FAILED|SKIPPED|All tests passed|test cases|rc=' "$O/test-$t.log" | sort -u | head -8 | tr '\n' ' ')"
done | tee "$O/bits.txt" | tee -a "$S"
echo "bits done at ${SECONDS} s" | tee -a "$S"
# 2. one-process A/B
FLIPFLOW_PLUGIN_PATH=$V/ab timeout 90 "$B/bin/pipeline" bench "$V/vor-ab.yaml" --device "$DEV" --sizes "$N" \
  --steps 100 --warmup 20 --results "$O/ab-results" > "$O/ab.txt" 2>&1
echo "== vor-ab rc=$? at ${SECONDS} s" | tee -a "$S"
grep -E "^[0-9]" "$O/ab.txt" | grep -oE "vor_ab\.[a-z0-9]+=[0-9.e+-]+" | tr '\n' ' ' | tee -a "$S"
echo | tee -a "$S"
grep -E "vor_ab\.[A-Za-z0-9]+/(area_mean|sides_variance|area_variance)" "$O/ab.txt" | sort | tee -a "$S"
# 3. plain bench-voronoi, interleaved: pairs (main, head) while a pair (2 x the last run's time)
# still ends before 170 s, at most 3 pairs
last=45
for k in 0 1 2; do
  ((SECONDS + 2 * last < 170)) || { echo "== plain pair $k skipped at ${SECONDS} s" | tee -a "$S"; break; }
  for v in main head; do
    t0=$SECONDS
    if [[ $v == main ]]; then unset FLIPFLOW_PLUGIN_PATH; else export FLIPFLOW_PLUGIN_PATH=$V/head:$B/plugins; fi
    timeout 60 "$B/bin/pipeline" bench "$B/pipelines/bench-voronoi.yaml" --device "$DEV" --sizes "$N" --steps 100 \
      --warmup 20 --results "$O/plain-results" > "$O/plain-$k-$v.txt" 2>&1
    echo "== plain $k $v rc=$? at ${SECONDS} s: $(grep -oE 'voronoi\.geometry=[0-9.e+-]+' "$O/plain-$k-$v.txt" | head -1)" | tee -a "$S"
    last=$((SECONDS - t0))
  done
done
unset FLIPFLOW_PLUGIN_PATH
rm -rf "$O/ab-results" "$O/plain-results"
echo "total: ${SECONDS} s" | tee -a "$S"
