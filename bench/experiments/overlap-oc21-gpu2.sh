#!/bin/bash
# oc21, second request (issue 20: overlap_correct's grid path at 2^20), GPU call of ~09:40 UTC:
#   bash run2.sh BUNDLE OUT       (about 150 s; every command has a timeout; writes OUT/oc21-2.txt)
# Call 3 (run.sh) showed that loading more at once loses: iteration 0's loads at once +0.087 ms,
# lane pairs another +0.05 (overlap_correct 0.794 / 0.844 against main's 0.707, round 2). So this
# call asks two things:
#   1. cg/ (variants2.tar.xz; branch oc21 on main 53d2f97, ABI 5, rpath $ORIGIN/../../lib): the
#      read-once arrays (neighbour lists, fans, degrees; seeds, moves and box crossings) loaded
#      through L2 only (ld.global.cg), so that the L1 keeps the positions that ~6 walks share.
#      Same registers (104), same bits by construction. bench-abp 2^20 (100 steps after 20),
#      main / cg / cg / main; the bundle's test_overlap_correct_cpu_cuda and
#      test_overlap_correct_walls [cuda] with cg first in FLIPFLOW_PLUGIN_PATH beside round 1's cg.
#   2. What main's correct_kernel waits on at 2^20: ncu of one launch after 20 warm-up steps
#      (warp states, scheduler, memory, source counters; --clock-control none), the details page
#      and the per-SASS-instruction page (xz) into OUT.
set -uo pipefail
SECONDS=0
B=$(cd "${1:?BUNDLE}" && pwd)
OUT=${2:?OUT}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
TMPD=$(mktemp -d /tmp/oc21b.XXXXXX)
V=$B/oc21
mkdir -p "$V"
tar xJf "$HERE/variants2.tar.xz" -C "$V" 2>/dev/null ||
  python3 -c "import tarfile, sys; tarfile.open(sys.argv[1]).extractall(sys.argv[2])" "$HERE/variants2.tar.xz" "$V"
export FLIPFLOW_TEST_DATA=$B/tests/data
S=$OUT/oc21-2.txt
{
  nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm,temperature.gpu --format=csv,noheader 2>/dev/null
  FLIPFLOW_PLUGIN_PATH=$V/cg timeout 20 "$B/bin/pipeline" stages > "$TMPD/abi.txt" 2>&1 ||
    { echo "!! cg does not load in this bundle:"; head -5 "$TMPD/abi.txt"; }
  bench() {  # $1: variant folder name, or - for the bundle's own plugins (main)
    if [[ $1 == - ]]; then unset FLIPFLOW_PLUGIN_PATH; else export FLIPFLOW_PLUGIN_PATH=$V/$1; fi
    echo "== round $2: bench-abp 2^20, ${1/#-/main} (from ${SECONDS} s)"
    timeout 45 "$B/bin/pipeline" bench "$B/pipelines/bench-abp.yaml" --device cuda --sizes 1048576 --steps 100 \
      --warmup 20 --results "$TMPD/results" 2>&1 | grep -E "^[0-9]|iterations per|pairs per|correction per|rror" | head -6
    unset FLIPFLOW_PLUGIN_PATH
  }
  bench - 1
  # The bits run beside round 1's cg bench (they can only slow cg down there); round 2 is clean.
  (
    export FLIPFLOW_PLUGIN_PATH=$V/cg:$B/plugins FLIPFLOW_TEST_DEVICE=cuda
    timeout 50 "$B/bin/test_overlap_correct_cpu_cuda" > "$TMPD/t1.txt" 2>&1
    echo "exit $?" >> "$TMPD/t1.txt"
    timeout 20 "$B/bin/test_overlap_correct_walls" "[cuda]" > "$TMPD/t2.txt" 2>&1
    echo "exit $?" >> "$TMPD/t2.txt"
  ) &
  bits=$!
  bench cg 1
  wait $bits
  echo "== cg: test_overlap_correct_cpu_cuda (CPU == CUDA), done at ${SECONDS} s"
  tail -4 "$TMPD/t1.txt"
  grep -B3 -A14 "FAILED" "$TMPD/t1.txt" | head -40
  echo "== cg: test_overlap_correct_walls [cuda]"
  tail -4 "$TMPD/t2.txt"
  grep -B3 -A14 "FAILED" "$TMPD/t2.txt" | head -20
  bench cg 2
  bench - 2
  NCU=$(command -v ncu || ls /usr/local/cuda*/bin/ncu /opt/nvidia/nsight-compute/*/ncu 2>/dev/null | head -n 1)
  echo "== ncu (${NCU:-none}) of main's correct_kernel, one launch after 20 steps (from ${SECONDS} s)"
  if [[ -n $NCU ]] && ((SECONDS < 135)); then
    timeout $((175 - SECONDS)) "$NCU" --target-processes all --clock-control none -k regex:correct_kernel \
      --launch-skip 20 --launch-count 1 \
      --section LaunchStats --section Occupancy --section SchedulerStats --section WarpStateStats \
      --section MemoryWorkloadAnalysis --section InstructionStats --section SpeedOfLight --section SourceCounters \
      -f -o "$OUT/oc" "$B/bin/pipeline" bench "$B/pipelines/bench-abp.yaml" --device cuda --sizes 1048576 \
      --steps 1 --warmup 25 --results "$TMPD/results-ncu" > "$OUT/ncu-run.txt" 2>&1
    echo "ncu rc=$? at ${SECONDS} s"
    if [[ -f $OUT/oc.ncu-rep ]]; then
      "$NCU" -i "$OUT/oc.ncu-rep" --page details > "$OUT/ncu-details.txt" 2>&1
      "$NCU" -i "$OUT/oc.ncu-rep" --page source --csv --print-source sass 2>&1 | xz > "$OUT/ncu-sass.csv.xz"
      grep -E "Duration|Registers Per|Achieved Occupancy|Issue Slots Busy|Executed Instructions  |No Eligible|Active Warps Per|Eligible Warps|Warp Cycles Per Issued|L1/TEX Hit|L2 Hit|DRAM Throughput|Memory Throughput|Mem Busy|Max Bandwidth|Compute \(SM\)" \
        "$OUT/ncu-details.txt" | cut -c1-140
      grep -iE "stall|long scoreboard|lg throttle|barrier|membar|mio" "$OUT/ncu-details.txt" | cut -c1-200 | head -30
    else
      tail -5 "$OUT/ncu-run.txt"
    fi
  else
    echo "ncu skipped"
  fi
  echo "total: ${SECONDS} s"
} 2>&1 | tee "$S"
rm -rf "$TMPD"
