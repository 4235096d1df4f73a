#!/bin/bash
# Hard disks in flipflow versus WCA disks in LAMMPS (fix brownian), side by side on this CPU, as
# simulated Brownian time per wall-clock second. One run measures both, interleaved (ROUNDS
# rounds of: one LAMMPS run, then flipflow at each Δt), so each ratio is taken under the same
# machine load; the machines are shared, so the load average is recorded in every round.
#
#   tools/bench/cpu_vs_lammps.sh [DT ...]          e.g. tools/bench/cpu_vs_lammps.sh 1e-3 3e-4
#
# Both: 2D disks, σ = 1, D = 1 (kT = γ = 1 in LAMMPS), so τ_B = σ²/D = 1; area fraction 0.5;
# N = 2^16; both cores.
#   LAMMPS: ../shared/peers/in.bd2d + run_lammps.sh (WCA, skin 0.3, square-lattice start),
#           2 MPI ranks, Δt = 2e-4 τ_B, the largest stable step for WCA (at 5e-4 particles are
#           lost; ../shared/peers/README.md); 2^27/N = 2048 timed steps after 512 warm-up.
#   flipflow: `pipeline bench` on pipelines/hard-disks.yaml (brownian.integrate D = 1,
#           delaunay.detect_inversion/flip/lawson, overlap_correct; bench leaves observers
#           out), 2 threads, at each DT given, FF_STEPS timed steps after 0.2 τ_B of warm-up.
#           Default DTs: 1e-3, the largest Δt whose hard-disk Z = 1 + 2η g(σ⁺) is within 3 %
#           of Henderson (η = 0.5, N = 4096, t = 1…21, 4 seeds: +2.9 % at 1e-3, +2.6 % at 9e-4;
#           +5.0 % at 2e-3; bench/README.md), and 3e-4, the Δt tests/test_hard_disk_eos.cpp
#           runs (+0.4…1.2 %).
# Under load the two degrade differently (LAMMPS's MPI ranks run in lockstep, so a core taken by
# another job stalls both; oneTBB threads steal work), so the per-round ratio moves with the load;
# the ratio of the best rounds estimates the ratio on an idle machine.
# The VM's two vCPUs share one L3 cache at times and sit on two L3 domains of the host CPU at
# others (bench/README.md, session 40): across L3 domains flipflow's threads, which share the
# particles' arrays, run ~1.6x slower, LAMMPS's MPI ranks do not. So each flipflow run is
# bracketed by tools/bench/core_to_core.cpp, a cache line's round trip between CPUs 0 and 1 (~50 ns
# on one L3, ~300+ across), and each round is tagged: "one L3" when both probes are under
# C2C_SPLIT ns (default 150), "two L3s" when both are over, else "moved" (it changed during the
# run); the ratios are also summarised over the one-L3 rounds.
# Simulated time per wall second = steps/s × Δt (bench's throughput pass: consecutive steps).
# A rolled-back step halves Δt for a while; bench reports rollbacks per step and the line is
# marked when there are any, since steps/s × Δt then overstates the simulated time.
#
# Environment: LMP (default /tmp/lmpsrc/build_deb/lmp_bd, built by
# ../shared/peers/build_lammps_bd.sh), BUILD (a flipflow build folder; default build-render if
# it has bin/pipeline, else build), PEERS (default ../shared/peers), N_EXP (default 16), ROUNDS
# (default 3), FF_STEPS (default 100), FF_WARMUP (default: 0.2 τ_B of steps, at least 50),
# PIPELINE_FILE (default pipelines/hard-disks.yaml of the tree BUILD was built from), OUT (default
# bench/results/cpu_vs_lammps.txt; the report is appended).
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
cd "$ROOT"
LMP=${LMP:-/tmp/lmpsrc/build_deb/lmp_bd}
PEERS=${PEERS:-$(cd "$ROOT/../shared/peers" 2>/dev/null && pwd || true)}
if [ -z "${BUILD:-}" ]; then
  if [ -x build-render/bin/pipeline ]; then BUILD=build-render; else BUILD=build; fi
fi
PIPELINE=$BUILD/bin/pipeline
N_EXP=${N_EXP:-16}
N=$((1 << N_EXP))
LMP_DT=2e-4
ROUNDS=${ROUNDS:-3}
FF_STEPS=${FF_STEPS:-100}
OUT=${OUT:-bench/results/cpu_vs_lammps.txt}
PY=/usr/bin/python3
DTS=("$@")
[ ${#DTS[@]} -gt 0 ] || DTS=(1e-3 3e-4)

die() { echo "cpu_vs_lammps: $*" >&2; exit 2; }
[ -x "$LMP" ] || die "no LAMMPS binary at $LMP (run ../shared/peers/build_lammps_bd.sh, ~6 min on 2 cores, or set LMP)"
[ -n "$PEERS" ] && [ -f "$PEERS/in.bd2d" ] && [ -x "$PEERS/run_lammps.sh" ] || die "no in.bd2d/run_lammps.sh in '$PEERS' (set PEERS)"
[ -x "$PIPELINE" ] || die "no $PIPELINE (build first, or set BUILD)"
command -v mpirun >/dev/null || die "no mpirun (apt-get install openmpi-bin)"

work=$(mktemp -d /tmp/cpu_vs_lammps.XXXXXX)
trap 'rm -rf "$work"' EXIT
C2C_SPLIT=${C2C_SPLIT:-150}
g++ -O2 -pthread "$ROOT/tools/bench/core_to_core.cpp" -o "$work/core_to_core" ||
  die "cannot build tools/bench/core_to_core.cpp with g++"
c2c() { "$work/core_to_core" || echo nan; }
report="$work/report.txt"
say() { echo "$*" | tee -a "$report"; }
load() { uptime | sed 's/.*load average: *//'; }

# Which source the pipeline binary was built from: its CMake source folder, at which commit, and
# whether that tree had uncommitted changes in the code (a shared checkout may).
src=$(sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$BUILD/CMakeCache.txt" 2>/dev/null || true)
src=${src:-$ROOT}
# The pipeline file from the same source tree as the binary (stages come and go).
PIPELINE_FILE=${PIPELINE_FILE:-$src/pipelines/hard-disks.yaml}
[ -f "$PIPELINE_FILE" ] || die "no $PIPELINE_FILE"
if git -C "$src" rev-parse --git-dir >/dev/null 2>&1; then
  rev="commit $(git -C "$src" rev-parse --short HEAD)"
  git -C "$src" diff --quiet HEAD -- core stages plugins tools/pipeline ||
    rev="$rev + uncommitted changes in $(git -C "$src" diff --name-only HEAD -- core stages plugins tools/pipeline |
      cut -d/ -f1-2 | sort -u | tr '\n' ' ')as of now; the binary is from $(date -u -r "$PIPELINE" +%H:%MZ)"
elif [ -f "$src/.flipflow-rev" ]; then
  rev="export of commit $(cat "$src/.flipflow-rev")"
else
  rev="unknown revision"
fi

say "== cpu_vs_lammps $(date -u +%Y-%m-%dT%H:%M:%SZ) on $(hostname): $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')"
say "   flipflow: $PIPELINE built from $src ($rev), $PIPELINE_FILE, 2 threads"
say "   LAMMPS: $LMP, fix brownian, WCA, 2 MPI ranks, Δt = $LMP_DT"
say "   N = $N, area fraction 0.5, σ = 1, D = 1 (τ_B = 1); $ROUNDS rounds of LAMMPS then flipflow at Δt = ${DTS[*]}"

for round in $(seq 1 "$ROUNDS"); do
  l0=$(load)
  RESULTS="$work/lammps_raw.txt" OMP_NUM_THREADS=1 PRE="mpirun --allow-run-as-root -np 2" \
    "$PEERS/run_lammps.sh" "$LMP" mpi2 bd "$LMP_DT" "" 1 "$N_EXP" > "$work/lammps.log" 2>&1 ||
    { cat "$work/lammps.log" >&2; die "LAMMPS failed (log above)"; }
  lmp_line=$(tail -n 1 "$work/lammps_raw.txt")
  for dt in "${DTS[@]}"; do
    warm=${FF_WARMUP:-$($PY -c "print(max(50, round(0.2/$dt)))")}
    rdir="$work/ff_${round}_$dt"
    c_before=$(c2c)
    "$PIPELINE" bench "$PIPELINE_FILE" --device cpu --threads 2 --sizes "$N" --steps "$FF_STEPS" --warmup "$warm" \
      --set run.dt="$dt" --results "$rdir" > "$work/ff.log" 2>&1 ||
      { cat "$work/ff.log" >&2; die "pipeline bench failed at Δt = $dt (log above)"; }
    c_after=$(c2c)
    for f in "$rdir"/*.jsonl; do sed "s/^{/{\"round\":$round,\"dt\":$dt,\"warmup\":$warm,\"load\":\"$l0\",\"lammps\":\"$lmp_line\",\"c2c\":[$c_before,$c_after],/" "$f"; done \
      >> "$work/ff.jsonl"
  done
  say "   round $round: load average before $l0, after $(load)"
done

$PY - "$work/ff.jsonl" "$LMP_DT" "$C2C_SPLIT" <<'EOF' | tee -a "$report"
import json, math, statistics, sys
rows = [json.loads(l.replace("nan", "NaN")) for l in open(sys.argv[1])]
lmp_dt = float(sys.argv[2])
split = float(sys.argv[3])
def placement(r):
    a, b = r["c2c"]
    if math.isnan(a) or math.isnan(b):
        return "unknown"
    return "one L3" if max(a, b) < split else "two L3s" if min(a, b) >= split else "moved"
def lmp(r):
    kv = dict(t.split("=", 1) for t in r["lammps"].split())
    return float(kv["steps_per_s"]), kv.get("dangerous", "?")
lsps = {r["round"]: lmp(r) for r in rows}
print("   LAMMPS steps/s per round: " + ", ".join(f"{s:.1f}" for s, _ in lsps.values())
      + f" (dangerous neighbour builds: {', '.join(d for _, d in lsps.values())}); median "
      f"{statistics.median(s for s, _ in lsps.values()):.1f} steps/s = "
      f"{statistics.median(s for s, _ in lsps.values()) * lmp_dt:.4g} tau_B per wall second")
for dt in sorted({r["dt"] for r in rows}, reverse=True):
    rs = [r for r in rows if r["dt"] == dt]
    sps = [r["steps_per_s"] for r in rs]
    ratios = [r["steps_per_s"] * dt / (lsps[r["round"]][0] * lmp_dt) for r in rs]
    rb = max(r["rollbacks_per_step"] for r in rs)
    flag = "" if rb == 0 else f"  [up to {rb:.3g} rollbacks per step: steps/s x dt overstates the simulated time]"
    print(f"flipflow dt = {dt:g}: steps/s per round " + ", ".join(f"{s:.3g}" for s in sps)
          + f"; median {statistics.median(sps):.3g} steps/s = {statistics.median(sps) * dt:.4g} tau_B per wall second; "
          f"ratio flipflow/LAMMPS per round " + ", ".join(f"{x:.3g} ({placement(r)}, {r['c2c'][0]:.0f}/{r['c2c'][1]:.0f} ns)" for x, r in zip(ratios, rs))
          + f", median {statistics.median(ratios):.3g}; best flipflow round / best LAMMPS round "
          f"{max(sps) * dt / (max(s for s, _ in lsps.values()) * lmp_dt):.3g}{flag}")
    one = [x for x, r in zip(ratios, rs) if placement(r) == "one L3"]
    if one:
        print(f"      over the {len(one)} round(s) on one L3: ratio median {statistics.median(one):.3g}, best {max(one):.3g}")
    last = rs[-1]
    st = ", ".join(f"{k} {v:.3g}" for k, v in sorted(last["stage_ms"].items(), key=lambda kv: -kv[1]))
    m = last["metrics_per_step"]
    print(f"      ms per step by stage (round {last['round']}): {st}; per step: overlap pairs "
          f"{m.get('overlap_correct/pairs', float('nan')):.4g}, overlap iterations {m.get('overlap_correct/iterations', float('nan')):.3g}, "
          f"Lawson flips {m.get('delaunay.lawson/lawson_flips', float('nan')):.4g}; warm-up {last['warmup']} steps, {last['steps']} timed")
EOF
say "   target: ratio >= 8 at N = 2^16 (issue 20)"

mkdir -p "$(dirname "$OUT")"
{ cat "$report"; echo; } >> "$OUT"
echo "appended to $OUT"
