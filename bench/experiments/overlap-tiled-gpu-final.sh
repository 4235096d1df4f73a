#!/bin/bash
# octile3 (issue 20 item 3): overlap_correct `scheme: tiled` on CUDA, final request (under 90 s).
#
#   bash gpu-carry/octile3/run.sh BUNDLE OUT      (BUNDLE: the lead's bundle of main, ABI 5)
#
# Shadow bundle as before: plugin variants (gzipped, rpath $ORIGIN/../../lib) in
# BUNDLE/octile3/<variant>, the branch's test_overlap_correct_cpu_cuda in BUNDLE/octile3/bin.
#   head: branch octile3 4f0c400, whose tiled kernel is call 3's e654d97 (work lists; bits passed)
#   b:    branch octile3b bf32d22: no check after the apply (each tile marks the next candidates as
#         it ends: a superset of jacobi's rule), two grid barriers a global iteration instead of three
# Everything goes to stdout (and OUT/all.txt).
#   1. bits: test_overlap_correct_cpu_cuda "[tiled]" with b (CPU == CUDA; head's passed in call 3);
#   2. one bench round at 2^14 only (no 2^20 set-up: seconds a bench): jacobi, b and head with tiles
#      of 256 (call 3, head: 0.191 ms against jacobi's 0.173), b 256x2, b 1024x4, jacobi again.
set -uo pipefail
SECONDS=0
C=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
B=$(cd "$1" && pwd)
OUT=$2
mkdir -p "$OUT"
exec > >(tee "$OUT/all.txt") 2>&1
S=$B/octile3
mkdir -p "$S/bin"
for v in head b; do
  mkdir -p "$S/$v"
  gzip -dc "$C/$v.so.gz" > "$S/$v/libflipflow_stage_overlap_correct.so"
done
gzip -dc "$C/test_overlap_correct_cpu_cuda.gz" > "$S/bin/test_overlap_correct_cpu_cuda"
chmod +x "$S/bin/test_overlap_correct_cpu_cuda"
export FLIPFLOW_TEST_DATA=$B/tests/data
RES=$(mktemp -d)
nvidia-smi -L
echo "== 1. bits (b)"
FLIPFLOW_PLUGIN_PATH=$S/b:$B/plugins timeout 45 "$S/bin/test_overlap_correct_cpu_cuda" "[tiled]" > "$RES/bits.txt" 2>&1
echo "exit $? after ${SECONDS} s"
grep -E "FAILED|^  [A-Za-z0-9(].*$|passed|failed" "$RES/bits.txt" | grep -v "^  SKIPPED" | head -40
echo "== 2. bench-abp 2^14, 200 steps after 20 (at ${SECONDS} s)"
bench() {  # variant, name, then --set arguments
  local v=$1 name=$2
  shift 2
  ((SECONDS < 72)) || { echo "-- $name ($v): skipped (${SECONDS} s)"; return; }
  echo "-- $name ($v)"
  FLIPFLOW_PLUGIN_PATH=$S/$v:$B/plugins timeout 14 "$B/bin/pipeline" bench "$B/pipelines/bench-abp.yaml" --device cuda \
    --sizes 16384 --steps 200 --warmup 20 --results "$RES" "$@" > "$RES/out.txt" 2>&1 || { echo "exit $?"; tail -3 "$RES/out.txt"; }
  grep -E "^[0-9]|overlap_correct/iterations per" "$RES/out.txt"
}
t=step.overlap_correct
bench b "jacobi" --set $t.scheme=jacobi
bench b "tiled 256x4" --set $t.scheme=tiled --set $t.tile=256
bench head "tiled 256x4" --set $t.scheme=tiled --set $t.tile=256
bench b "tiled 256x2" --set $t.scheme=tiled --set $t.tile=256 --set $t.inner=2
bench b "tiled 1024x4" --set $t.scheme=tiled
bench b "jacobi again" --set $t.scheme=jacobi
rm -rf "$RES"
echo "total: ${SECONDS} s"
