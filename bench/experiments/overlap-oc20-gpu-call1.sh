#!/bin/bash
# (Kept for the record: the variants archive it unpacks lived in gpu-carry/oc20 outside the
# repository; the plugins are built from the commits named in bench/experiments/README.md, session 17.)
# oc20 (issue 20, overlap_correct at 2^20), GPU call 1:  bash run1.sh BUNDLE OUT   (under 3 minutes)
# BUNDLE: the lead's bundle of main (ABI 5). Unpacks variants1.tar.xz (next to this script) into
# BUNDLE/oc20/<variant>/libflipflow_stage_overlap_correct.so (rpath $ORIGIN/../../lib):
#   prof      main's stage + a phase profile (block 0's %globaltimer per phase and iteration, clock64
#             per particle); prints its table to stderr when the run ends
#   fan       iteration 0 keeps last step's fan when it is still the particle's (no walk)
#   all3      fan + the gather computes the new position (the apply only stores it) + the later
#             gathers load the whole neighbour list with the degree
#   team8     all3 + iterations after one that moved <= 4096 run in 8 blocks (own barrier), not the grid
#   team24    all3 + the same with 24 blocks below 16384 moved
#   echeck    team24 + the check after an iteration that moved > n/4 particles runs over the edges
#   ahead     echeck + a thread loads its next particle's list while it works on this one
#   prof3     all3 + the phase profile (no -lineinfo)
#   tests/test_overlap_correct  the branch's test (adds "CPU and CUDA give the same bits over many
#             steps of ABP": abp.yaml at φ = 0.7, N = 20000 and 100000, 150 steps, every step's
#             iterations and pairs and the final positions and images)
# Steps (logs in OUT: bits.txt, ab.txt, profile.txt, ncu-*): 1 bits of ahead, which holds every
# change (the branch's test_overlap_correct [cuda], walls [cuda], test_cpu_cuda_bits); 2 bench-abp
# 2^20, main against the candidates, interleaved, 2 rounds; 3 the phase profile at 2^20 after 20
# and after 3000 warm-up steps, main (prof) and all3 (prof3); 4 ncu of one kernel launch (stall
# reasons), if time is left.
set -uo pipefail
SECONDS=0
B=$(cd "${1:-${BUNDLE:-bundle}}" && pwd)
OUT=${2:-${OUT:-/tmp/oc20-out}}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
# OUT gets at most 7 files (the device tool brings back 8): scratch goes to TMPD
TMPD=$(mktemp -d /tmp/oc20.XXXXXX)
V=$B/oc20
mkdir -p "$V"
tar xJf "$HERE/variants1.tar.xz" -C "$V" 2>/dev/null ||
  python3 -c "import tarfile, sys; tarfile.open(sys.argv[1]).extractall(sys.argv[2])" "$HERE/variants1.tar.xz" "$V"
P=$B/pipelines/bench-abp.yaml
PIPE=$B/bin/pipeline
CANDS="fan all3 team8 team24 echeck ahead"
# the tests find pipelines/*.yaml at FLIPFLOW_TEST_DATA/../.. (tests/support/cli.h): the bundle's
export FLIPFLOW_TEST_DATA=$B/tests/data
{
  nvidia-smi --query-gpu=name,clocks.sm,clocks.mem --format=csv
  command -v ncu && ncu --version | tail -1
} > "$TMPD/env.txt" 2>&1
cat "$TMPD/env.txt"

# 1. bits: ahead holds every change of the others (team8 differs from team24 in two constants
# only); the others are tested one by one only if it fails
{
  cat "$TMPD/env.txt"
  echo "== ahead: test_overlap_correct [cuda]"
  FLIPFLOW_PLUGIN_PATH=$V/ahead:$B/plugins timeout 60 "$V/tests/test_overlap_correct" "[cuda]" > "$TMPD/t.txt" 2>&1
  tail -3 "$TMPD/t.txt"
  if grep -q -i -E "failed|error" "$TMPD/t.txt" || ! grep -q -E "passed" "$TMPD/t.txt"; then
    grep -B3 -A14 -E "FAILED|error" "$TMPD/t.txt" | head -60
    for c in fan all3 team24 echeck; do
      echo "== $c: test_overlap_correct [cuda]"
      FLIPFLOW_PLUGIN_PATH=$V/$c:$B/plugins timeout 40 "$V/tests/test_overlap_correct" "[cuda]" 2>&1 | tail -3
    done
  fi
  echo "== ahead: test_overlap_correct_walls [cuda]"
  FLIPFLOW_PLUGIN_PATH=$V/ahead:$B/plugins timeout 30 "$B/bin/test_overlap_correct_walls" "[cuda]" 2>&1 | tail -3
  echo "== ahead: test_cpu_cuda_bits (shipped pipelines, 1000 steps, CPU == CUDA)"
  FLIPFLOW_PLUGIN_PATH=$V/ahead:$B/plugins timeout 60 "$B/bin/test_cpu_cuda_bits" \
    "CPU and CUDA give the same bits: shipped pipelines, double, 1000 steps" 2>&1 | tail -3
} > "$OUT/bits.txt" 2>&1
cat "$OUT/bits.txt"
echo "-- bits done at ${SECONDS} s"

# 2. speed: main (-) and the candidates, interleaved, each bench on its own (a failure skips one)
for r in 1 2; do
  ((r == 2 && SECONDS > 110)) && { echo "== round 2 skipped (${SECONDS} s spent)"; break; }
  for c in - $CANDS; do
    if [[ $c == - ]]; then unset FLIPFLOW_PLUGIN_PATH; else export FLIPFLOW_PLUGIN_PATH=$V/$c; fi
    echo "== round $r: ${c/#-/main}"
    timeout 45 "$PIPE" bench "$P" --device cuda --sizes 1048576 --steps 100 --warmup 20 --results "$TMPD/results" 2>&1 |
      grep -E "^[0-9]|iterations per|overlap_correct|error" | head -8
  done
done > "$OUT/ab.txt" 2>&1
unset FLIPFLOW_PLUGIN_PATH
cat "$OUT/ab.txt"
echo "-- A/B done at ${SECONDS} s"

# 3. phase profile of main's stage (prof) and of all3 (prof3); the table goes to stderr at the end
for wp in 20:prof 20:prof3 3000:prof 3000:prof3; do
  w=${wp%:*} pv=${wp#*:}
  ((SECONDS > 160)) && { echo "== profile $pv, warm-up $w: skipped (${SECONDS} s spent)" >> "$OUT/profile.txt"; continue; }
  echo "== profile $pv, warm-up $w" >> "$OUT/profile.txt"
  FLIPFLOW_PLUGIN_PATH=$V/$pv timeout 40 "$PIPE" bench "$P" --device cuda --sizes 1048576 --steps 30 --warmup $w \
    --results "$TMPD/results" >> "$OUT/profile.txt" 2>&1
done
cat "$OUT/profile.txt"
echo "-- profile done at ${SECONDS} s"

# 4. ncu: one launch of correct_kernel (main's stage + the profile's atomics,
# which are a few per block and phase), warp stall reasons per SASS line
if command -v ncu > /dev/null && ((SECONDS < 130)); then
  left=$((170 - SECONDS))
  FLIPFLOW_PLUGIN_PATH=$V/prof timeout $left ncu -k regex:correct_kernel --launch-skip 22 --launch-count 1 \
    --section LaunchStats --section Occupancy --section WarpStateStats --section SourceCounters \
    --section MemoryWorkloadAnalysis --section SchedulerStats -o "$TMPD/oc" -f \
    "$PIPE" bench "$P" --device cuda --sizes 1048576 --steps 3 --warmup 20 --results "$TMPD/results" \
    > "$TMPD/ncu-run.txt" 2>&1
  tail -5 "$TMPD/ncu-run.txt" | tee -a "$OUT/profile.txt"
  if [[ -f $TMPD/oc.ncu-rep ]]; then
    timeout 20 ncu --import "$TMPD/oc.ncu-rep" --page details > "$OUT/ncu-details.txt" 2>&1
    timeout 20 ncu --import "$TMPD/oc.ncu-rep" --page source --csv --print-source sass 2>&1 | gzip > "$OUT/ncu-sass.csv.gz"
    timeout 20 ncu --import "$TMPD/oc.ncu-rep" --page source --csv --print-source cuda 2>&1 | gzip > "$OUT/ncu-cuda.csv.gz"
    grep -E "Stall|Warp Cycles|Issued|Eligible|Active Warps|Registers|Achieved|Memory Throughput|L1/TEX Hit|L2 Hit|Duration" \
      "$OUT/ncu-details.txt" | head -60
    ls -la "$OUT"
  fi
fi
echo "total: ${SECONDS} s" | tee -a "$OUT/profile.txt"
