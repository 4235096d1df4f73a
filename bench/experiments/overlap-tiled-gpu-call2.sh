#!/bin/bash
# octile3 (issue 20 item 3): overlap_correct `scheme: tiled` on CUDA, GPU request 2 (under 150 s).
#
#   bash gpu-carry/octile3/run.sh BUNDLE OUT      (BUNDLE: the lead's bundle of main, ABI 5)
#
# Shadow bundle as in request 1: variants of libflipflow_stage_overlap_correct.so (gzipped here,
# rpath $ORIGIN/../../lib) in BUNDLE/octile3/<variant>, the branch's test_overlap_correct_cpu_cuda
# in BUNDLE/octile3/bin; FLIPFLOW_PLUGIN_PATH puts a variant first. Variants:
#   head:     branch octile3 f545413: particle work lists in the tiled kernel (jacobi's marks; a tile
#             without a candidate does nothing; inner iterations over active members only), and
#             iteration 0 in wide kernels where the grid has more particles than threads (2^20)
#   headprof: head + block 0's globaltimer per phase and the host call's time, printed at exit
#   lists:    e654d97 (work lists, no wide iteration 0): bits only, and only if head fails them
# Everything goes to stdout (and OUT/all.txt).
#   1. where a tiled step's time goes now (headprof, bench-abp 2^14 and 2^20, tile 1024, inner 4);
#   2. bits: test_overlap_correct_cpu_cuda "[tiled]" with head (CPU == CUDA);
#   3. speed: jacobi vs tiled head, interleaved (headprof in 1 is a second tiled sample).
set -uo pipefail
SECONDS=0
C=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
B=$(cd "$1" && pwd)
OUT=$2
mkdir -p "$OUT"
exec > >(tee "$OUT/all.txt") 2>&1
S=$B/octile3
mkdir -p "$S/bin"
for v in head headprof lists; do
  mkdir -p "$S/$v"
  gzip -dc "$C/$v.so.gz" > "$S/$v/libflipflow_stage_overlap_correct.so"
done
gzip -dc "$C/test_overlap_correct_cpu_cuda.gz" > "$S/bin/test_overlap_correct_cpu_cuda"
chmod +x "$S/bin/test_overlap_correct_cpu_cuda"
export FLIPFLOW_TEST_DATA=$B/tests/data
RES=$(mktemp -d)
nvidia-smi -L

bench() {  # variant, name, seconds, then --set arguments
  local v=$1 name=$2 secs=$3
  shift 3
  echo "-- $name ($v, at ${SECONDS} s)"
  FLIPFLOW_PLUGIN_PATH=$S/$v:$B/plugins timeout "$secs" "$B/bin/pipeline" bench "$B/pipelines/bench-abp.yaml" \
    --device cuda --sizes 16384,1048576 --steps 200 --warmup 20 --results "$RES" "$@" > "$RES/out.txt" 2>&1
  local rc=$?
  grep -E "^[0-9]|overlap_correct/(iterations|pairs) per|tiled profile" "$RES/out.txt"
  ((rc == 0)) || { echo "bench $name: exit $rc"; tail -5 "$RES/out.txt"; }
}
bits() {  # variant, seconds, filter
  echo "-- bits $1 \"$3\" (at ${SECONDS} s)"
  FLIPFLOW_PLUGIN_PATH=$S/$1:$B/plugins timeout "$2" "$S/bin/test_overlap_correct_cpu_cuda" "$3" > "$RES/bits.txt" 2>&1
  local rc=$?
  echo "exit $rc after ${SECONDS} s"
  grep -E "FAILED|^  [A-Za-z0-9(].*$|passed|failed" "$RES/bits.txt" | grep -v "^  SKIPPED" | head -50
  return $rc
}
tiled=(--set step.overlap_correct.scheme=tiled)
echo "== 1. profile"
bench headprof "tiled 1024x4" 35 "${tiled[@]}"
echo "== 2. bits"
bits head 50 "[tiled]" || { ((SECONDS < 90)) && bits lists 30 "*sizes, tiles, inner*"; }
echo "== 3. speed"
((SECONDS < 95)) && bench head "jacobi" 28 --set step.overlap_correct.scheme=jacobi
((SECONDS < 120)) && bench head "tiled 1024x4" 28 "${tiled[@]}"
rm -rf "$RES"
echo "total: ${SECONDS} s"
