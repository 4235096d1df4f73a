#!/bin/bash
# oc22 (issue 20: overlap_correct's CUDA time at 2^20), GPU call of ~11:50 UTC:
#   bash run.sh BUNDLE OUT      (about 170 s; every command has a timeout; writes OUT/oc22-1.txt)
# Arms (variants.tar.xz: plugins built on branch oc22 at 546e83c = main f2c9466, which has oc21's
# two-pass gather, + oc22's commits; ABI 5, rpath $ORIGIN/../lib):
#   main    the bundle's own plugins (main's HEAD: the two-pass gather is in since f2c9466)
#   wide    the grid's iteration 0 in three ordinary kernels (gather, apply, check; a thread per
#           particle, 64 registers, 4 blocks of 256 an SM against the cooperative kernel's 2),
#           the cooperative kernel from iteration 1 (branch oc22)
#   wide2   wide with iterations 0 and 1 so (kWideIterations = 2;
#           bench/experiments/overlap-oc22-two-wide-iterations.patch)
#   lists   wide + iteration 0's lists (kept-fan checks, fan walks) in a kernel of their own before
#           its gather, at 8 blocks an SM (32 registers); the gather reads the lists
#           (bench/experiments/overlap-oc22-lists-kernel.patch)
# Each variant runs from a shadow of the bundle: bin/ copies of pipeline, run-tests and the tests,
# lib, tests and pipelines linked, plugins/ the bundle's with overlap_correct swapped. (bin/run-tests
# unsets FLIPFLOW_PLUGIN_PATH, so a variant can only be tested through run-tests that way; the
# bench runs the shadow's pipeline, the same binary as the bundle's.) Besides, oc22's own build of
# test_overlap_correct_cpu_cuda runs its one new case (CPU == CUDA where max_iterations 1-3 stops a
# step at 20000 disks, the grid path) against the variant.
# Order: the bits of wide, wide2 and lists (run-tests, in the background beside round 1: ~45 s
# each alone), bench-abp 2^20 (100 steps after 20) round 1 (main, wide, wide2), round 2 reversed
# (wide2, wide, main), then while time is left (a run starts only before 150 s; each takes ~23 s
# at 2^20, mostly the set-up): bench-abp 2^16 main, wide, wide, main; lists once at 2^20;
# phoretic-c2-short 2^20 (50 steps after 20) for wide and main.
set -uo pipefail
SECONDS=0
B=$(cd "${1:?BUNDLE}" && pwd)
OUT=${2:?OUT}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
W=$(mktemp -d "${TMPDIR:-/tmp}/oc22.XXXXXX")
trap 'rm -rf "$W"' EXIT
SIZES=${OC22_SIZES:-1048576} DEVICE=${OC22_DEVICE:-cuda}  # (a dry run without a GPU: OC22_SIZES=4096 OC22_DEVICE=cpu)
unset FLIPFLOW_PLUGIN_PATH
tar xJf "$HERE/variants.tar.xz" -C "$W" 2>/dev/null ||
  python3 -c "import tarfile, sys; tarfile.open(sys.argv[1]).extractall(sys.argv[2])" "$HERE/variants.tar.xz" "$W"
S=$OUT/oc22-1.txt
shadow() {  # shadow VARIANT: $W/b-VARIANT, the bundle with the variant's overlap_correct
  local v=$1 d=$W/b-$1
  mkdir -p "$d/bin" "$d/plugins"
  for x in lib tests pipelines; do ln -s "$B/$x" "$d/$x"; done
  cp "$B/bin/run-tests" "$B/bin/pipeline" "$B"/bin/test_overlap_correct{,_cpu_cuda,_walls} "$d/bin/"
  cp "$W/test_overlap_correct_cpu_cuda" "$d/bin/oc22_test_overlap_correct_cpu_cuda"  # (not test_*: run alone)
  cp "$B"/plugins/*.so "$d/plugins/"
  cp "$W/$v/libflipflow_stage_overlap_correct.so" "$d/plugins/"
  timeout 20 "$d/bin/pipeline" stages > "$W/stages-$v.txt" 2>&1 ||
    { echo "!! $v does not load in this bundle:"; head -5 "$W/stages-$v.txt"; }
}
bench() {  # bench ARM ROUND PIPELINE STEPS
  local arm=$1 r=$2 pl=$3 steps=$4 bin=$B/bin/pipeline
  [[ $arm != main ]] && bin=$W/b-$arm/bin/pipeline
  echo "== round $r: ${pl%.yaml} $SIZES, $arm (from ${SECONDS} s)"
  timeout 60 "$bin" bench "$B/pipelines/$pl" --device "$DEVICE" --sizes "$SIZES" --steps "$steps" --warmup 20 \
    --results "$W/results" 2>&1 | grep -E "^[0-9]|iterations per|pairs per|rror" | head -6
}
{
  nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm,temperature.gpu --format=csv,noheader 2>/dev/null
  head -n 1 "$B/.flipflow-bundle" 2>/dev/null
  for v in wide wide2 lists; do shadow $v; done
  md5sum "$B/plugins/libflipflow_stage_overlap_correct.so" "$W"/b-*/plugins/libflipflow_stage_overlap_correct.so | sed "s|$W/||"
  # The bits, beside round 1 (they can only slow round 1 down; round 2 is clean).
  for v in wide wide2 lists; do
    (cd "$W/b-$v" && FLIPFLOW_TEST_DEVICE=$DEVICE timeout 150 bin/run-tests test_overlap_correct_cpu_cuda \
      test_overlap_correct test_overlap_correct_walls > "$W/tests-$v.txt" 2>&1; echo "exit $?" >> "$W/tests-$v.txt"
     echo "-- oc22's new case (its own build of test_overlap_correct_cpu_cuda):" >> "$W/tests-$v.txt"
     FLIPFLOW_TEST_DEVICE=$DEVICE timeout 60 bin/oc22_test_overlap_correct_cpu_cuda "*max_iterations on the grid*" 2>&1 |
       tail -n 25 >> "$W/tests-$v.txt") &
  done
  for arm in main wide wide2; do bench $arm 1 bench-abp.yaml 100; done
  wait
  for v in wide wide2 lists; do
    echo "== $v: run-tests test_overlap_correct_cpu_cuda test_overlap_correct test_overlap_correct_walls (FLIPFLOW_TEST_DEVICE=$DEVICE)"
    head -c 6000 "$W/tests-$v.txt"
  done
  for arm in wide2 wide main; do bench $arm 2 bench-abp.yaml 100; done
  # Then while time is left (a run starts only before 150 s): wide at 2^16 (each run ~5 s: does
  # the wide path's three extra launches cost where a step is short?), lists, phoretic.
  for arm in main wide wide main; do
    if ((SECONDS > 150)); then echo "== bench-abp 65536: $arm skipped (${SECONDS} s)"; continue; fi
    SIZES=65536 bench $arm 2^16 bench-abp.yaml 100
  done
  for arm in lists; do
    if ((SECONDS > 150)); then echo "== bench-abp: $arm skipped (${SECONDS} s)"; continue; fi
    bench $arm 3 bench-abp.yaml 100
  done
  for arm in wide main; do
    if ((SECONDS > 150)); then echo "== phoretic-c2-short: $arm skipped (${SECONDS} s)"; continue; fi
    bench $arm 1 phoretic-c2-short.yaml 50
  done
  echo "total: ${SECONDS} s"
} 2>&1 | tee "$S"
