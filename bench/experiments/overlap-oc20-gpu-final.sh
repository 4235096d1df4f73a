#!/bin/bash
# (Kept for the record: the variants archive it unpacks lived in gpu-carry/oc20 outside the
# repository; the plugins are built from the commits named in bench/experiments/README.md, session 17.)
# oc20 (issue 20, overlap_correct at 2^20), final GPU call (< 60 s):  bash run3.sh BUNDLE OUT
# Unpacks variants3.tar.xz (next to this script) into BUNDLE/oc20c/: final/ (the branch's head,
# oc20: iteration 0 keeps last step's fans, the gather computes the new position so the apply
# only stores it, later lists loaded with their degree; rpath $ORIGIN/../../lib) and
# tests/test_overlap_correct_cpu_cuda (the branch's). About 60 s:
#   1. bits: CPU == CUDA over 150 steps of ABP at φ = 0.7 (N = 20000, 100000: every step's
#      iterations and pairs, final positions and images) and one correction at 3000 … 100000,
#      beside the first bench;
#   2. bench-abp 2^20 (100 steps after 20) with final, then with main's plugin (or, with a third
#      argument nofan, with nofan/: final without the kept fans, which alone did not gain in call 1).
# Writes OUT/run3.txt.
set -uo pipefail
SECONDS=0
B=$(cd "${1:-${BUNDLE:-bundle}}" && pwd)
OUT=${2:-${OUT:-/tmp/oc20-out3}}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
TMPD=$(mktemp -d /tmp/oc20c.XXXXXX)
V=$B/oc20c
mkdir -p "$V"
tar xJf "$HERE/variants3.tar.xz" -C "$V" 2>/dev/null ||
  python3 -c "import tarfile, sys; tarfile.open(sys.argv[1]).extractall(sys.argv[2])" "$HERE/variants3.tar.xz" "$V"
export FLIPFLOW_TEST_DATA=$B/tests/data
# The bundle's plugin ABI: 5 (main before graph4) takes final/ and tests/; 6 (graph4's segment
# graphs merged) takes final6/ and tests6/, the same head built on oc20 merged with graph4.
T=tests
ALT=${3:--}
if ! FLIPFLOW_PLUGIN_PATH=$V/final "$B/bin/pipeline" stages > "$TMPD/abi.txt" 2>&1; then
  if grep -q "ABI version 5, this flipflow has version 6" "$TMPD/abi.txt"; then
    rm -rf "$V/final" "$V/nofan" "$V/tests"
    mv "$V/final6" "$V/final"
    T=tests6
    echo "bundle of ABI 6: the head built on oc20 + graph4 (no nofan for ABI 6: main instead)" | tee "$OUT/run3.txt"
    ALT=-
  else
    cat "$TMPD/abi.txt"
  fi
fi
{
  # The bits run beside the first bench (final's): its set-up is ~20 s of host work, the test
  # ~15 s. If the test reaches into final's timed passes it can only slow final down, so a gain
  # of final over main measured this way is not the test's doing. Main's bench runs after it.
  FLIPFLOW_PLUGIN_PATH=$V/final:$B/plugins timeout 40 "$V/$T/test_overlap_correct_cpu_cuda" \
    "*many steps of ABP*,*either device path*" > "$TMPD/t.txt" 2>&1 &
  bits=$!
  for c in final "$ALT"; do
    if [[ $c == - ]]; then unset FLIPFLOW_PLUGIN_PATH; else export FLIPFLOW_PLUGIN_PATH=$V/$c; fi
    if [[ $c != final ]]; then
      wait $bits
      echo "== final: test_overlap_correct_cpu_cuda, CPU == CUDA cases (done at ${SECONDS} s)"
      tail -3 "$TMPD/t.txt"
      grep -B3 -A14 "FAILED" "$TMPD/t.txt" | head -40
    fi
    echo "== bench-abp 2^20, ${c/#-/main} (from ${SECONDS} s)"
    timeout 35 "$B/bin/pipeline" bench "$B/pipelines/bench-abp.yaml" --device cuda --sizes 1048576 --steps 100 \
      --warmup 20 --results "$TMPD/results" 2>&1 | grep -E "^[0-9]|iterations per|pairs per|error" | head -4
  done
  echo "total: ${SECONDS} s"
} 2>&1 | tee -a "$OUT/run3.txt"
