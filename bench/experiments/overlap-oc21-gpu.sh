#!/bin/bash
# oc21 (issue 20: overlap_correct's grid path at 2^20), GPU call of ~09:40 UTC:
#   bash run.sh BUNDLE OUT        (about 160 s; every command has a timeout; writes OUT/oc21.txt)
# Unpacks variants.tar.xz (next to this script) into BUNDLE/oc21/: two builds of
# libflipflow_stage_overlap_correct.so from branch oc21 (on main c2f936c, ABI 5; rpath
# $ORIGIN/../../lib):
#   spec/    iteration 0's one-thread gather loads a particle's degree, list, fan, vertex edge and
#            position at once, and its listed neighbours' positions beside the half-edge loads that
#            test whether last step's fan is kept (2 load latencies in the chain instead of 5)
#   specg2/  spec + lane pairs (2 lanes a particle, each half of the list, shuffle-added fixed-point
#            sums) for the later gathers and for every check while a block has > 128 to do, and the
#            next particle's index loaded a particle ahead
# Then, on the GPU:
#   1. bench-abp 2^20 (100 steps after 20), interleaved: main's plugin, spec, specg2, then
#      specg2, spec, main (round 2 in reverse order);
#   2. bits, beside round 1's spec and specg2 benches (which can only slow them down there; round
#      2 starts after the tests end and is clean): the bundle's own test_overlap_correct_cpu_cuda (CPU == CUDA: sizes on both sides of
#      the thresholds, shared GPUs, 150 steps of ABP) and test_overlap_correct_walls [cuda], with
#      specg2's plugin first in FLIPFLOW_PLUGIN_PATH (specg2 holds every code path spec has).
set -uo pipefail
SECONDS=0
B=$(cd "${1:?BUNDLE}" && pwd)
OUT=${2:?OUT}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
TMPD=$(mktemp -d /tmp/oc21.XXXXXX)
V=$B/oc21
mkdir -p "$V"
tar xJf "$HERE/variants.tar.xz" -C "$V" 2>/dev/null ||
  python3 -c "import tarfile, sys; tarfile.open(sys.argv[1]).extractall(sys.argv[2])" "$HERE/variants.tar.xz" "$V"
export FLIPFLOW_TEST_DATA=$B/tests/data
{
  nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm,temperature.gpu --format=csv,noheader 2>/dev/null
  for c in spec specg2; do
    FLIPFLOW_PLUGIN_PATH=$V/$c timeout 20 "$B/bin/pipeline" stages > "$TMPD/abi-$c.txt" 2>&1 ||
      { echo "!! $c does not load in this bundle:"; head -5 "$TMPD/abi-$c.txt"; }
  done
  bench() {  # $1: variant folder name, or - for the bundle's own plugins (main)
    if [[ $1 == - ]]; then unset FLIPFLOW_PLUGIN_PATH; else export FLIPFLOW_PLUGIN_PATH=$V/$1; fi
    echo "== round $2: bench-abp 2^20, ${1/#-/main} (from ${SECONDS} s)"
    timeout 45 "$B/bin/pipeline" bench "$B/pipelines/bench-abp.yaml" --device cuda --sizes 1048576 --steps 100 \
      --warmup 20 --results "$TMPD/results" 2>&1 | grep -E "^[0-9]|iterations per|pairs per|correction per|rror" | head -6
    unset FLIPFLOW_PLUGIN_PATH
  }
  bench - 1
  # The bits run beside round 1's variant benches (they can only slow the variants down there);
  # round 2 starts after they end, so it is clean.
  (
    export FLIPFLOW_PLUGIN_PATH=$V/specg2:$B/plugins FLIPFLOW_TEST_DEVICE=cuda
    timeout 50 "$B/bin/test_overlap_correct_cpu_cuda" > "$TMPD/t1.txt" 2>&1
    echo "exit $?" >> "$TMPD/t1.txt"
    timeout 20 "$B/bin/test_overlap_correct_walls" "[cuda]" > "$TMPD/t2.txt" 2>&1
    echo "exit $?" >> "$TMPD/t2.txt"
  ) &
  bits=$!
  bench spec 1
  bench specg2 1
  wait $bits
  echo "== specg2: test_overlap_correct_cpu_cuda (CPU == CUDA), done at ${SECONDS} s"
  tail -4 "$TMPD/t1.txt"
  grep -B3 -A14 "FAILED" "$TMPD/t1.txt" | head -40
  echo "== specg2: test_overlap_correct_walls [cuda]"
  tail -4 "$TMPD/t2.txt"
  grep -B3 -A14 "FAILED" "$TMPD/t2.txt" | head -20
  bench specg2 2
  bench spec 2
  bench - 2
  echo "total: ${SECONDS} s"
} 2>&1 | tee "$OUT/oc21.txt"
rm -rf "$TMPD"
