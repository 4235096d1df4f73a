#!/bin/bash
# The Delaunay issue's GPU runs, from a bundle (tools/bundle) on a GPU node:
#   1. pipeline bench of pipelines/brownian-delaunay.yaml (delaunay.sort, brownian.integrate,
#      detect_inversion + flip + lawson; observers are left out by bench) at N = 2^14 ... 2^20,
#      and of the same pipeline without delaunay.sort (particles in random memory order);
#   2. the pipeline itself: 10^5 steps at N = 2^16, the triangulation checked against CGAL every
#      10^4 steps (delaunay.check stops the run on a mismatch), H5MD frames with the triangles
#      (/connectivity/delaunay.triangles) every 10^4 steps; summarized with h5py if the node has
#      it (the trajectory itself, ~33 MB, stays on the node: OUT takes files up to 16 MiB).
#
#   tools/bench/gpu_delaunay.sh BUNDLE_DIR          (results in $OUT, default ./gpu-out)
#
# Files written under $OUT (5): gpu_delaunay.txt (summary: device, bench tables, run result),
# bench.jsonl (bench JSON lines, sorted and unsorted), bench.log, run.log (the run's output),
# run_check.txt (h5py summary of the trajectory, or why there is none).
#
# Environment (defaults are the issue's case; small values test the script on a CPU):
#   DEVICE=cuda  SIZES=2^14,2^16,2^18,2^20  STEPS=200  WARMUP=20
#   RUN_N (pipeline's 65536)  RUN_STEPS (100000)  EVERY (10000: check, triangles, h5md)
#   RUN=1 (0: skip the run)  BENCH=1 (0: skip the benchmarks)
set -uo pipefail
B=${1:?usage: tools/bench/gpu_delaunay.sh BUNDLE_DIR}
B=$(cd "$B" && pwd) || exit 2
OUT=${OUT:-gpu-out}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
DEVICE=${DEVICE:-cuda}
SIZES=${SIZES:-2^14,2^16,2^18,2^20}
STEPS=${STEPS:-200}
WARMUP=${WARMUP:-20}
RUN=${RUN:-1}
BENCH=${BENCH:-1}
P="$B/bin/pipeline"
PY=python3  # the one with h5py if there is one (Debian's /usr/bin/python3 has it where installed)
for c in /usr/bin/python3 python3; do
  if $c -c "import h5py, numpy" 2>/dev/null; then PY=$c; break; fi
done
PIPE="$B/pipelines/brownian-delaunay.yaml"
[ -x "$P" ] || { echo "gpu_delaunay: no $P" >&2; exit 2; }
[ -f "$PIPE" ] || { echo "gpu_delaunay: no $PIPE" >&2; exit 2; }
work=$(mktemp -d /tmp/gpu_delaunay.XXXXXX)
trap 'rm -rf "$work"' EXIT
summary="$OUT/gpu_delaunay.txt"
: > "$summary"
say() { echo "$*" | tee -a "$summary"; }

say "== gpu_delaunay $(date -u +%Y-%m-%dT%H:%M:%SZ) on $(hostname), device $DEVICE"
if command -v nvidia-smi >/dev/null; then
  say "   $(nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader 2>&1 | head -n 1)"
fi
say "   bundle $B; $(nproc) CPU cores: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')"

status=0
if [ "$BENCH" = 1 ]; then
  grep -v "stage: delaunay.sort" "$PIPE" > "$work/brownian-delaunay-unsorted.yaml"
  for f in "$PIPE" "$work/brownian-delaunay-unsorted.yaml"; do
    "$P" bench "$f" --device "$DEVICE" --sizes "$SIZES" --steps "$STEPS" --warmup "$WARMUP" --results "$work/bench" \
      >> "$OUT/bench.log" 2>&1 || { status=1; say "   bench of $(basename "$f") failed: see bench.log"; }
  done
  # bench names its file <pipeline>-<backend>.jsonl (<pipeline>.jsonl in older builds)
  : > "$OUT/bench.jsonl"
  for f in "$work"/bench/brownian-delaunay*.jsonl; do [[ $f == *unsorted* ]] || cat "$f" >> "$OUT/bench.jsonl"; done
  for f in "$work"/bench/brownian-delaunay-unsorted*.jsonl; do [ -f "$f" ] && cat "$f" >> "$OUT/bench.jsonl"; done
  $PY - "$OUT/bench.jsonl" <<'EOF' 2>&1 | tee -a "$summary"
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
print("\n| pipeline | N | detect | flip | lawson | maintenance (ms) | integrate | whole step (median ms) | steps/s | lawson flips/step | rollbacks/step |")
print("|---|---|---|---|---|---|---|---|---|---|---|")
for r in rows:
    s, m = r["stage_ms"], r["metrics_per_step"]
    d, f, l = s["delaunay.detect_inversion"], s["delaunay.flip"], s["delaunay.lawson"]
    name = "unsorted" if "unsorted" in r["pipeline"] else "sorted"
    print(f"| {name} | {r['N']} | {d:.3g} | {f:.2g} | {l:.3g} | {d + f + l:.3g} | {s.get('brownian.integrate', 0):.3g} "
          f"| {r['median_ms']:.3g} | {r['steps_per_s']:.4g} | {m.get('delaunay.lawson/lawson_flips', 0):.4g} "
          f"| {r['rollbacks_per_step']:.3g} |")
print()
EOF
fi

if [ "$RUN" = 1 ]; then
  set_args=()
  [ -n "${RUN_N:-}" ] && set_args+=(--set "system.N=$RUN_N")
  [ -n "${RUN_STEPS:-}" ] && set_args+=(--set "run.steps=$RUN_STEPS")
  if [ -n "${EVERY:-}" ]; then
    for s in delaunay.check delaunay.triangles observe.h5md; do set_args+=(--set "step.$s.every=$EVERY"); done
  fi
  t0=$(date +%s)
  "$P" run "$PIPE" --device "$DEVICE" --out "$work/run" --force "${set_args[@]}" > "$OUT/run.log" 2>&1
  rc=$?
  t1=$(date +%s)
  [ $rc -eq 0 ] || status=1
  say "== run: pipeline run $(basename "$PIPE") --device $DEVICE ${set_args[*]}: exit $rc after $((t1 - t0)) s"
  say "   $(grep -E '^(done|run failed)' "$OUT/run.log" | tail -n 1)"
  traj="$work/run/trajectory.h5"
  [ -f "$traj" ] || traj="$work/run/trajectory.h5.partial"
  if [ ! -f "$traj" ]; then
    echo "no trajectory was written" > "$OUT/run_check.txt"
  elif ! $PY -c "import h5py, numpy" 2>/dev/null; then
    echo "no h5py on this node: the trajectory ($(stat -c %s "$traj") bytes) was not checked" > "$OUT/run_check.txt"
  else
    $PY - "$traj" > "$OUT/run_check.txt" 2>&1 <<'EOF'
import sys
import numpy as np
import h5py
f = h5py.File(sys.argv[1], "r")
pos = f["particles/all/position"]
g = f["connectivity/delaunay.triangles"]
L = f["particles/all/box/edges"][:]
n = pos["value"].shape[1]
print(f"{sys.argv[1]}: N = {n}, frames at steps {list(pos['step'][:])}")
print(f"triangle frames at steps {list(g['step'][:])}, shape {g['value'].shape}")
obs = f["observables"]
for k in ("delaunay.check/checked", "delaunay.check/mismatches", "delaunay.check/ties", "rollbacks", "dt"):
    if k in obs:
        print(f"{k}: {list(obs[k]['value'][:])}")
bad = 0
for k in range(g["value"].shape[0]):
    t = g["value"][k]
    x = pos["value"][k]
    ab = x[t[:, 1]] - x[t[:, 0]]
    ac = x[t[:, 2]] - x[t[:, 0]]
    ab -= L * np.rint(ab / L)
    ac -= L * np.rint(ac / L)
    cross = ab[:, 0] * ac[:, 1] - ab[:, 1] * ac[:, 0]
    d = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]).astype(np.int64)
    twins = np.array_equal(np.sort(d[:, 0] * n + d[:, 1]), np.sort(d[:, 1] * n + d[:, 0]))
    frame_bad = int((cross <= 0).sum()) + (0 if twins and len(t) == 2 * n else 1)
    bad += frame_bad
    print(f"frame {k} (step {g['step'][k]}): {len(t)} triangles, {int((cross <= 0).sum())} not positive, "
          f"every edge with its twin: {twins}")
print("triangles OK" if bad == 0 else "TRIANGLES BAD")
EOF
  fi
  say "   $(tail -n 1 "$OUT/run_check.txt")"
fi
say "== exit $status"
exit $status
