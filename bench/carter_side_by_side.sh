#!/bin/bash
# flipflow's whole hard-disk step against Carter et al.'s own GPU program (issue 20's row:
# ≥ 10× at every size), both on the same GPU in one command.
#
#   bench/carter_side_by_side.sh BUNDLE PEERS_BUNDLE OUT [small|2p20|all]
#
# BUNDLE: flipflow's (`tools/bundle build`); PEERS_BUNDLE: a copy of ../shared/peers-gpu/bundle
# (Carter's `colloids-bench`, built for sm_90); OUT: where carter.log, the flipflow bench's
# jsonl and side_by_side.txt go. small = N 2^14, 2^16, 2^18 (~1.5 min); 2p20 = N 2^20 (Carter's
# integrate is all-pairs: ~2 min at 30 steps); all = both. What compares: Carter's maintenance
# (his step − his integrate: update triangles, check, flips, overlap correction, medians over the
# timed steps) against flipflow's whole step (pipelines/bench-hd07.yaml: integrate, detect, flip,
# Lawson, overlap correction), both Brownian hard disks at φ = 0.7, Δt = 0.01, the same noise.
set -u
B=$(cd "$1" && pwd); PB=$(cd "$2" && pwd); OUT=$3; JOB=${4:-small}
mkdir -p "$OUT"; OUT=$(cd "$OUT" && pwd)
case $JOB in
  small) sizes=16384,65536,262144; jobs=carter-small ;;
  2p20) sizes=1048576; jobs=carter-2p20 ;;
  all) sizes=16384,65536,262144,1048576; jobs="carter-small carter-2p20" ;;
  *) echo "carter_side_by_side: JOB is small, 2p20 or all (got '$JOB')" >&2; exit 2 ;;
esac
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
pipe=$B/pipelines/bench-hd07.yaml; [[ -f $pipe ]] || pipe=$here/../pipelines/bench-hd07.yaml
CARTER_WARMUP=${CARTER_WARMUP:-20} CARTER_STEPS=${CARTER_STEPS:-100} CARTER_STEPS_2P20=${CARTER_STEPS_2P20:-30} \
  CARTER_OWN_STEPS=0 bash "$PB/run_all.sh" "$OUT" $jobs > "$OUT/carter-run.txt" 2>&1
echo "carter rc=$?" >> "$OUT/carter-run.txt"
"$B/bin/pipeline" bench "$pipe" --device cuda --sizes $sizes --steps 100 --warmup 20 --results "$OUT" \
  > "$OUT/flipflow-bench.txt" 2>&1
echo "flipflow rc=$?" >> "$OUT/flipflow-bench.txt"
python3 - "$OUT" <<'PY' | tee "$OUT/side_by_side.txt"
import glob, json, re, sys
out = sys.argv[1]
carter = {}
for line in open(f"{out}/carter.log", errors="replace"):
    if line.startswith("RESULT code=carter"):
        kv = dict(re.findall(r"(\w+)=(\S+)", line))
        carter[int(kv["N"])] = (float(kv["maintenance_median_ms"]), float(kv["median_ms"]))
ff = {}
for f in glob.glob(f"{out}/bench-hd07-cuda*.jsonl"):
    for line in open(f):
        r = json.loads(line)
        ff[int(r["N"])] = (r["median_ms"], 1e3 / r["steps_per_s"])
# flipflow's step two ways: the median of steps each followed by a wait for the device (what
# this script reported until session 23), and the mean of steps in a row (1 / steps per s, what a
# run sees: the next step's kernels queue behind the last one's). The ratio is taken on the second.
print("Brownian hard disks, phi = 0.7, dt = 0.01, ms per step, same GPU")
print(f"{'N':>8} {'Carter maintenance':>19} {'Carter step':>12} {'flipflow synced':>16} {'flipflow in a row':>18} {'ratio':>7} {'synced':>7}")
for n in sorted(set(carter) | set(ff)):
    c = carter.get(n); f = ff.get(n)
    ratio = f"{c[0] / f[1]:.2f}x" if c and f else "-"
    synced = f"{c[0] / f[0]:.2f}x" if c and f else "-"
    print(f"{n:>8} {c[0] if c else '-':>19} {c[1] if c else '-':>12} {f'{f[0]:.4g}' if f else '-':>16} "
          f"{f'{f[1]:.4g}' if f else '-':>18} {ratio:>7} {synced:>7}")
print("ratio: Carter's maintenance / flipflow's step in a row; synced: / flipflow's synced median")
print("target (issue 20): flipflow's whole step >= 10x faster than Carter's maintenance at every size")
PY
