#!/bin/bash
# oc22, final request (issue 20: overlap_correct, the wide kernels), GPU call of ~12:40 UTC:
#   bash run2.sh BUNDLE OUT     (about 115 s; every command has a timeout; writes OUT/oc22-2.txt)
# Call 2 (11:03) measured wide (the grid's iteration 0 in three ordinary kernels at 4 blocks an SM,
# the cooperative kernel from iteration 1; branch oc22) at 2^20 in one clean round: overlap_correct
# 0.622 against main's 0.672 ms, same iterations, bits pass on CUDA. This call asks, with no tests
# beside the benches:
#   1. where a step is short, do the wide path's three extra launches cost? bench-abp at 2^14 and
#      2^16 (grid path: n > 4096), main / wide / wide / main (in the same processes as 3.);
#   2. phoretic-c2-short 2^20 (50 steps after 20): wide, main (target <= 1.0 ms a step; 1.076 now);
#   3. bench-abp 2^20 once more, main then wide (call 2's clean round was wide then main).
# wide: variants.tar.xz's wide/ (rebuilt at 11:18 on branch oc22 at 179547c = main f69bb85 merged; ABI 5, rpath
# $ORIGIN/../lib), run from a shadow of the bundle (bin/pipeline copied, lib linked, plugins/ the
# bundle's with overlap_correct swapped), as in run.sh.
set -uo pipefail
SECONDS=0
B=$(cd "${1:?BUNDLE}" && pwd)
OUT=${2:?OUT}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
W=$(mktemp -d "${TMPDIR:-/tmp}/oc22.XXXXXX")
trap 'rm -rf "$W"' EXIT
DEVICE=${OC22_DEVICE:-cuda} BIG=${OC22_BIG:-1048576}  # (a dry run without a GPU: OC22_DEVICE=cpu OC22_BIG=8192)
unset FLIPFLOW_PLUGIN_PATH
tar xJf "$HERE/variants.tar.xz" -C "$W" wide 2>/dev/null ||
  python3 -c "import tarfile, sys; tarfile.open(sys.argv[1]).extractall(sys.argv[2])" "$HERE/variants.tar.xz" "$W"
d=$W/b-wide
mkdir -p "$d/bin" "$d/plugins"
for x in lib tests pipelines; do ln -s "$B/$x" "$d/$x"; done
cp "$B/bin/pipeline" "$d/bin/"
cp "$B"/plugins/*.so "$d/plugins/"
cp "$W/wide/libflipflow_stage_overlap_correct.so" "$d/plugins/"
bench() {  # bench ARM PIPELINE SIZES STEPS
  local arm=$1 pl=$2 sizes=$3 steps=$4 bin=$B/bin/pipeline
  [[ $arm == wide ]] && bin=$d/bin/pipeline
  echo "== ${pl%.yaml} $sizes, $arm (from ${SECONDS} s)"
  timeout 60 "$bin" bench "$B/pipelines/$pl" --device "$DEVICE" --sizes "$sizes" --steps "$steps" --warmup 20 \
    --results "$W/results" 2>&1 | grep -E "^[0-9]|iterations per|rror" | head -12
}
{
  nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm,temperature.gpu --format=csv,noheader 2>/dev/null
  head -n 1 "$B/.flipflow-bundle" 2>/dev/null
  md5sum "$B/plugins/libflipflow_stage_overlap_correct.so" "$d/plugins/libflipflow_stage_overlap_correct.so" | sed "s|$W/||"
  timeout 20 "$d/bin/pipeline" stages > "$W/stages.txt" 2>&1 || { echo "!! wide does not load:"; head -5 "$W/stages.txt"; }
  bench main bench-abp.yaml 16384,65536,$BIG 100
  bench wide bench-abp.yaml 16384,65536,$BIG 100
  bench wide phoretic-c2-short.yaml $BIG 50
  bench main phoretic-c2-short.yaml $BIG 50
  for arm in wide main; do  # the small sizes' second round, reversed (a run starts only before 108 s)
    if ((SECONDS > 108)); then echo "== bench-abp 16384,65536: $arm skipped (${SECONDS} s)"; continue; fi
    bench $arm bench-abp.yaml 16384,65536 100
  done
  echo "total: ${SECONDS} s"
} 2>&1 | tee "$OUT/oc22-2.txt"
