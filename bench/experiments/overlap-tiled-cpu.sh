#!/bin/bash
# The runs behind bench/experiments/README.md's "Tiled global iterations" section (session 19,
# branch octile): bench-abp at 2^14 (or N) on the CPU (2 threads), BUILD_DIR a build of a tree
# with overlap-tiled-cpu.patch applied (its environment switches pick the scheme; without
# FF_OC_TILE the stage is main's). About 15 minutes at 2^14 on 2 cores.
#   bash overlap-tiled-cpu.sh BUILD_DIR WORK_DIR [N]
# Per configuration: global iterations, pairs and particle-gathers per step over the 40 steps whose
# metrics `pipeline bench` reports (its second pass of --steps), inner iterations per tile per
# global iteration, iterations before the GPU's one-block tail would start (the previous iteration
# moved <= 512 particles), and the fraction of Delaunay edges between two tiles (unshifted).
# Physics (same build, same variables): test_hard_disk_eos -s; pipelines/abp-carter-phi0.4.yaml
# with steps 3000, an observe.h5md every 3000 and --set run.seed=42..45 (MSD at t = 30 from
# /observables/observe.msd/msd/value).
set -euo pipefail
build=$1 work=$2 n=${3:-16384}
repo=$(cd "$(dirname "$0")/../.." && pwd)
mkdir -p "$work/logs"
cd "$work"
sed "s/N: 1048576/N: $n/" "$repo/pipelines/bench-abp.yaml" > early.yaml
sed -e 's/steps: 1000/steps: 3000/' early.yaml > abp3000.yaml
echo "  - {stage: observe.h5md, every: 3000, file: frame.h5, fields: [position, image, orientation]}" >> abp3000.yaml
[ -f jac3000/frame.h5 ] || "$build/bin/pipeline" run abp3000.yaml --device cpu --threads 2 --out "$work/jac3000" --force
# from jacobi's 3000-step frame (delaunay.sort renumbers it afresh at configure)
sed -e "s#init: triangular_lattice_sample#init: {from: $work/jac3000/frame.h5, frame: -1}#" early.yaml > from3000.yaml

stats() {  # LOG WARMUP STEPS T
  python3 - "$@" "$n" <<'EOF'
import sys
log, warm, last, T, n = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5])
steps = []
for line in open(log):  # k bad pairs gathers tile_its active moved cross
    v = list(map(int, line.split()))
    if v[0] == 0: steps.append([])
    steps[-1].append(v)
assert len(steps) == warm + 3 * last
steps = steps[warm + last:warm + 2 * last]
S = len(steps)
ap = [[r for r in s if r[1] > 0] for s in steps]  # iterations that moved (the check that ends a step is not one)
it = sum(map(len, ap)) / S
tail = sum(sum(1 for i, r in enumerate(a) if i == 0 or a[i - 1][6] > 512) for a in ap) / S
nt = (n + T - 1) // T if T else 1
out = f"iterations {it:.2f}  pairs {sum(r[2] for a in ap for r in a) / S:.0f}  gathers {sum(r[3] for s in steps for r in s) / S / n:.2f} N"
out += f"  before tail {tail:.2f}"
if T:
    out += f"  inner/tile {sum(r[4] for a in ap for r in a) / S / it / nt:.2f}  cross-tile edges {sum(s[0][7] for s in steps) / S / (3 * n):.3f}"
print(out)
EOF
}

run() {  # TAG YAML WARMUP T M [ENV...]
  local tag=$1 yaml=$2 warm=$3 T=$4 m=$5; shift 5
  env FF_OC_TILE=$T FF_OC_TILE_INNER=$m "$@" FF_OC_LOG="$work/logs/$tag.log" \
    "$build/bin/pipeline" bench "$yaml" --steps 40 --warmup "$warm" --device cpu --threads 2 > "$work/logs/$tag.out"
  echo "$tag: $(stats "$work/logs/$tag.log" "$warm" 40 "$T")"
}

for phase in early:early.yaml:20 from3000:from3000.yaml:0 own3000:early.yaml:3000; do
  IFS=: read -r p yaml warm <<< "$phase"
  run "$p-jacobi" "$yaml" "$warm" 0 1
  for T in 256 1024; do
    for m in 2 4 64; do
      run "$p-T$T-m$m" "$yaml" "$warm" "$T" "$m"
      run "$p-T$T-m$m-shift" "$yaml" "$warm" "$T" "$m" FF_OC_TILE_SHIFT=1
    done
    # tiles by spatial cells, made once per step (FF_OC_TILE_CELLS=2), shifted grid in odd iterations
    run "$p-T$T-m4-cells-shift" "$yaml" "$warm" "$T" 4 FF_OC_TILE_SHIFT=1 FF_OC_TILE_CELLS=2
  done
done
