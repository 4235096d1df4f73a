#!/usr/bin/env bash
# Carter et al.'s cases c0–c4 (pipelines/phoretic-cK-short.yaml, short range, Carter's noise
# convention D = 0.005 since issue 18 C2): the numbers the benchmark tables of bench/README.md
# need, and the morphology numbers of each case, into one text file.
#
#   bench/carter_c0c4.sh            from a bundle (bundle/bin/pipeline) or a build (build/bin/pipeline)
#
# 1. `pipeline bench` of each case at BENCH_SIZES (default 2^20), STEPS = 50 after WARMUP = 10
#    (the protocol of the c0–c4 tables: latency pass steps 60–109): the table row (N, median ms
#    per step, steps/s, ..., ms per stage) and the metric lines (overlap iterations per step,
#    Lawson flips per step, ...). Every bench line is kept.
# 2. Morphology: each case run with its observers replaced by observe.clusters (bond 1.1σ) on all
#    particles and on each species (ids all, A, B), called once after the last step: the numbers
#    tests/test_carter_morphology.cpp checks (unlike_fraction, largest_fraction, monomers,
#    aggregates, mean_aggregate_size, coordination, bonds, percolating). At MORPH ("N:steps"
#    pairs, default "4096:10000 65536:10000": the paper's size, whose CPU numbers README.md
#    quotes (CPU and CUDA give the same bits for these pipelines, so they must come out equal),
#    and 16× more particles for as long), seed 1.
#
# Environment: OUT (default ./carter-out), DEVICE (cuda when a GPU is visible, else cpu),
# PIPELINE_BIN, BENCH_SIZES (none: morphology only), STEPS, WARMUP, MORPH, CASES (default "0 1 2 3 4").
# Writes $OUT/carter_c0c4.txt (and the runs' CSVs under $OUT/morph/). On an H100 the defaults
# take about 1.5–2 minutes (most of it building the 2^20 triangulations on the host).
set -euo pipefail
die() { echo "carter_c0c4: error: $*" >&2; exit 1; }
since() { awk -v a="$1" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }'; }

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bin=${PIPELINE_BIN:-}
if [[ -z $bin ]]; then
  for c in "$root/bundle/bin/pipeline" "$root/build/bin/pipeline"; do
    [[ -x $c ]] && { bin=$c; break; }
  done
fi
[[ -n $bin && -x $bin ]] || die "no pipeline executable (build or bundle first, or set PIPELINE_BIN)"
pipes="$root/pipelines"
[[ -f $pipes/phoretic-c0-short.yaml ]] || pipes="$(dirname "$(dirname "$bin")")/pipelines"
[[ -f $pipes/phoretic-c0-short.yaml ]] || die "no pipelines/phoretic-c0-short.yaml next to this script or the bundle"
device=${DEVICE:-}
if [[ -z $device ]]; then
  if command -v nvidia-smi >/dev/null && nvidia-smi -L >/dev/null 2>&1; then device=cuda; else device=cpu; fi
fi
out=${OUT:-$PWD/carter-out}
mkdir -p "$out/morph"
out=$(cd "$out" && pwd)
txt=$out/carter_c0c4.txt
cases=${CASES:-0 1 2 3 4}
morph=${MORPH:-4096:10000 65536:10000}
commit=$(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo "unknown (bundle)")

{
  echo "# carter_c0c4: $(date -u +%Y-%m-%dT%H:%MZ), device $device, commit $commit, pipeline $bin"
  [[ $device == cuda ]] && nvidia-smi --query-gpu=name,driver_version --format=csv,noheader 2>/dev/null | sed 's/^/# GPU: /'
  echo "# bench: sizes ${BENCH_SIZES:-2^20}, ${STEPS:-50} steps after ${WARMUP:-10}; morphology: $morph (N:steps), seed 1"
} > "$txt"

echo "== bench" >> "$txt"
[[ ${BENCH_SIZES:-} == none ]] && echo "(skipped: BENCH_SIZES=none)" >> "$txt"
for c in $cases; do
  [[ ${BENCH_SIZES:-} == none ]] && break
  f=$pipes/phoretic-c$c-short.yaml
  echo "-- c$c ($f)" >> "$txt"
  t0=$(date +%s.%N)
  "$bin" bench "$f" --device "$device" --sizes "${BENCH_SIZES:-2^20}" --steps "${STEPS:-50}" \
    --warmup "${WARMUP:-10}" --results "$out/bench-results" > "$out/bench-c$c.log" 2>&1 ||
    { cat "$out/bench-c$c.log" >&2; die "bench of c$c failed (log: $out/bench-c$c.log)"; }
  cat "$out/bench-c$c.log" >> "$txt"
  echo "(c$c bench wall $(since "$t0") s)" >> "$txt"
done

# The case's pipeline with its observers (observe.h5md, observe.progress) replaced by three
# observe.clusters, each called once, after the last step.
morph_yaml() {  # case steps file
  grep -v -E '^\s*- \{stage: observe\.' "$pipes/phoretic-c$1-short.yaml"
  local t
  for t in all A B; do
    local types="[]"
    [[ $t != all ]] && types="[$t]"
    echo "  - {stage: observe.clusters, id: $t, every: $2, bond: 1.1, types: $types, file: clusters-$t.csv, sizes_file: sizes-$t.csv}"
  done
}

echo "== morphology (observe.clusters, bond 1.1 sigma, after the last step; columns as in clusters.csv)" >> "$txt"
for c in $cases; do
  for nm in $morph; do
    n=${nm%%:*} steps=${nm##*:}
    d=$out/morph/c$c-N$n
    mkdir -p "$d"
    morph_yaml "$c" "$steps" > "$d/pipeline.yaml"
    t0=$(date +%s.%N)
    "$bin" run "$d/pipeline.yaml" --device "$device" --out "$d" --force \
      --set system.N="$n" --set run.steps="$steps" --set run.seed=1 > "$d/run.log" 2>&1 ||
      { tail -20 "$d/run.log" >&2; die "morphology run of c$c at N = $n failed (log: $d/run.log)"; }
    wall=$(since "$t0")
    echo "-- c$c N=$n steps=$steps (run wall $wall s)" >> "$txt"
    for t in all A B; do
      csv=$d/clusters-$t.csv
      [[ -f $csv ]] || die "no $csv after the run of c$c at N = $n"
      # One line per selection: "column=value ..." from the header and the last row.
      awk -F, -v sel="$t" '/^#/ { next }
        !seen { for (i = 1; i <= NF; ++i) h[i] = $i; seen = 1; next }
        { last = $0 }
        END { n = split(last, v, ","); line = sel ":"; for (i = 1; i <= n; ++i) line = line " " h[i] "=" v[i]; print line }' \
        "$csv" >> "$txt"
    done
  done
done
echo "done: $txt"
