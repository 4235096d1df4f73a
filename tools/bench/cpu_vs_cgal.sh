#!/bin/bash
# Maintaining the Delaunay triangulation in flipflow versus CGAL 5.5 re-triangulating, side by
# side on this CPU. For each N, CGAL and flipflow run back to back (the machines are shared:
# the ratio is taken under the same load; uptime is recorded before, between and after).
#
#   tools/bench/cpu_vs_cgal.sh [EXP ...]        N = 2^EXP; default 14 16 18 (add 20 if time allows)
#
# CGAL: ../shared/peers/cgal_bench.cpp (built here with run_cgal.sh's flags: -O3 -DNDEBUG
#   -std=c++17, -lgmp -lmpfr), one thread. Uniform random points in a square box of side
#   L = sqrt(N π / 2) (area fraction 0.5 of unit disks); each step moves every point by a
#   Gaussian of std 0.01·√2 per coordinate (DΔt = 1e-4). Reported: periodic rebuild per step,
#   periodic move_point of every vertex per step, and a plain Delaunay of the points plus their
#   periodic images within 3 of the boundary ("plain + ghost", the fastest CGAL way).
# flipflow: `pipeline bench` on pipelines/brownian-delaunay.yaml (delaunay.sort,
#   brownian.integrate D = 0.01 at Δt = 0.01: DΔt = 1e-4 as above; σ = 1 at packing fraction 0.5:
#   the same L; init random = random sequential addition, so the points do not overlap, unlike
#   the peer's; observers are left out by bench), both threads. Maintenance = the per-stage ms of
#   delaunay.detect_inversion + delaunay.flip + delaunay.lawson (each stage waited for); the
#   whole step (median, includes integration and the core's rollback snapshot) is shown too.
#   The same pipeline without delaunay.sort (particles in random memory order) is measured as
#   well, unless UNSORTED=0.
# Ratio = fastest CGAL way / flipflow maintenance (target >= 10).
#
# Environment: BUILD (default: build, or build-check if build has no bin/pipeline), PEERS
# (default ../shared/peers), CGAL_REPS (default 3), FF_STEPS (timed steps per pass, default 100),
# FF_WARMUP (default 20), UNSORTED (default 1), OUT (default bench/results/cpu_vs_cgal.txt; the
# report is appended).
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
cd "$ROOT"
PEERS=${PEERS:-$(cd "$ROOT/../shared/peers" 2>/dev/null && pwd || true)}
if [ -z "${BUILD:-}" ]; then
  if [ -x build/bin/pipeline ]; then BUILD=build; else BUILD=build-check; fi
fi
PIPELINE=$BUILD/bin/pipeline
PIPELINE_FILE=pipelines/brownian-delaunay.yaml
CGAL_REPS=${CGAL_REPS:-3}
FF_STEPS=${FF_STEPS:-100}
FF_WARMUP=${FF_WARMUP:-20}
UNSORTED=${UNSORTED:-1}
OUT=${OUT:-bench/results/cpu_vs_cgal.txt}
PY=/usr/bin/python3
EXPS=("$@")
[ ${#EXPS[@]} -gt 0 ] || EXPS=(14 16 18)

die() { echo "cpu_vs_cgal: $*" >&2; exit 2; }
[ -n "$PEERS" ] && [ -f "$PEERS/cgal_bench.cpp" ] || die "no cgal_bench.cpp in '$PEERS' (set PEERS)"
[ -x "$PIPELINE" ] || die "no $PIPELINE (build first, or set BUILD)"
[ -f "$PIPELINE_FILE" ] || die "no $PIPELINE_FILE"
grep -q "stage: delaunay.sort" "$PIPELINE_FILE" || die "$PIPELINE_FILE no longer starts with delaunay.sort"

work=$(mktemp -d /tmp/cpu_vs_cgal.XXXXXX)
trap 'rm -rf "$work"' EXIT
report="$work/report.txt"
say() { echo "$*" | tee -a "$report"; }
load() { uptime | sed 's/.*load average/load average/'; }

CGAL_BIN=$BUILD/cgal_bench
if [ ! -x "$CGAL_BIN" ] || [ "$PEERS/cgal_bench.cpp" -nt "$CGAL_BIN" ]; then
  echo "building $CGAL_BIN from $PEERS/cgal_bench.cpp ..." >&2
  g++ -O3 -DNDEBUG -std=c++17 "$PEERS/cgal_bench.cpp" -o "$CGAL_BIN" -lgmp -lmpfr || die "cannot build cgal_bench"
fi
grep -v "stage: delaunay.sort" "$PIPELINE_FILE" > "$work/brownian-delaunay-unsorted.yaml"

say "== cpu_vs_cgal $(date -u +%Y-%m-%dT%H:%M:%SZ) on $(hostname): $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')"
say "   flipflow $(git -C "$ROOT" rev-parse --short HEAD)$(git -C "$ROOT" diff --quiet HEAD -- core stages plugins tools/pipeline 2>/dev/null || echo '+local changes') ($PIPELINE, $PIPELINE_FILE, 2 threads); CGAL 5.5 ($CGAL_BIN, 1 thread, median of $CGAL_REPS)"
say "   ms per step; maintenance = detect_inversion + flip + lawson; ratio = fastest CGAL / maintenance"
say "   load before: $(load)"

bench_ff() {  # file N tag -> prints the JSON line of the run
  local rdir="$work/ff_$3_$2"
  "$PIPELINE" bench "$1" --device cpu --threads 2 --sizes "$2" --steps "$FF_STEPS" --warmup "$FF_WARMUP" \
    --results "$rdir" > "$work/ff_$3_$2.log" 2>&1 || { cat "$work/ff_$3_$2.log" >&2; die "pipeline bench failed at N = $2 (log above)"; }
  cat "$rdir"/*.jsonl | tail -1
}

rows="$work/rows.txt"
: > "$rows"
for e in "${EXPS[@]}"; do
  N=$((1 << e))
  cgal=$("$CGAL_BIN" "$N" "$CGAL_REPS" "$CGAL_REPS" 1 2>&1 | grep '^RESULT') || die "cgal_bench failed at N = $N"
  ff=$(bench_ff "$PIPELINE_FILE" "$N" sorted)
  unsorted="{}"
  [ "$UNSORTED" = 1 ] && unsorted=$(bench_ff "$work/brownian-delaunay-unsorted.yaml" "$N" unsorted)
  echo "$e|$cgal|$ff|$unsorted|$(load)" >> "$rows"
  say "   N = 2^$e done; $(load)"
done

$PY - "$rows" <<'EOF' | tee -a "$report"
import json, sys
print()
print("| N | CGAL periodic rebuild | CGAL move_point all | CGAL plain + ghost | flipflow detect | flip | lawson "
      "| **maintenance** | **ratio** | whole step (median) | integrate | maintenance, unsorted particles (ratio) |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|")
notes = []
for line in open(sys.argv[1]):
    e, cgal, ff, uns, load = line.rstrip("\n").split("|", 4)
    c = dict(t.split("=", 1) for t in cgal.split()[1:])
    rebuild, move, ghost = float(c["p_rebuild_ms"]), float(c["p_move_point_ms"]), float(c["np_ghost_build_ms"])
    fastest = min(rebuild, move, ghost)
    r = json.loads(ff)
    st = r["stage_ms"]
    det, flip, law = st["delaunay.detect_inversion"], st["delaunay.flip"], st["delaunay.lawson"]
    maint = det + flip + law
    u = json.loads(uns)
    ucell = "—"
    if u:
        us = u["stage_ms"]
        um = us["delaunay.detect_inversion"] + us["delaunay.flip"] + us["delaunay.lawson"]
        ucell = f"{um:.3g} ({fastest / um:.3g}×)"
    print(f"| 2^{e} | {rebuild:.4g} | {move:.4g} | {ghost:.4g} | {det:.3g} | {flip:.2g} | {law:.3g} | **{maint:.3g}** "
          f"| **{fastest / maint:.3g}×** | {r['median_ms']:.3g} | {st['brownian.integrate']:.3g} | {ucell} |")
    m = r["metrics_per_step"]
    notes.append(f"2^{e}: lawson flips/step {m.get('delaunay.lawson/lawson_flips', 0):.4g}, "
                 f"rounds/step {m.get('delaunay.lawson/lawson_rounds', 0):.3g}, candidates/step "
                 f"{m.get('delaunay.detect_inversion/lawson_candidates', 0):.4g}, rollbacks/step {r['rollbacks_per_step']:.3g}; "
                 f"CGAL periodic build {float(c['p_build_ms']):.4g} ms, plain build {float(c['np_build_ms']):.4g} ms; {load}")
print()
for n in notes:
    print("   " + n)
EOF
say "   load after: $(load)"
say "   target: ratio >= 10 (flipflow maintenance vs the fastest CGAL way)"

mkdir -p "$(dirname "$OUT")"
{ cat "$report"; echo; } >> "$OUT"
echo "appended to $OUT"
