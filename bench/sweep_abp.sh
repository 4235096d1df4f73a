#!/bin/bash
# `pipeline sweep` on one GPU: many runs of ABP at N = 2^14, φ = 0.7 (pipelines/bench-abp.yaml,
# replicas differing in run.seed) at once, on threads of one process (--in-process) and in child
# processes (with CUDA MPS when it starts, and without), against one run alone (`pipeline bench`
# and a sweep with --concurrent 1). Issue 20's target: 64 runs at once, aggregate >= 5e8
# particle-steps/s (one run alone: ~8e7).
#
#   bench/sweep_abp.sh [BUNDLE_DIR]      (default: the bundle this script sits in, else ./bundle)
#
# Environment: OUT (where sweep.txt and the index files go; default ./sweep-bench-out), STEPS
# (steps per run, default 10000: at 2000 the runs' start-up was a large part of the sweep,
# bench/README.md session 13), N (default 16384), PIPELINE_BIN (default BUNDLE/bin/pipeline),
# DEVICE (default cuda; cpu to try the script on a machine without a GPU), QUICK=1 (only 64 runs
# at once in one process and under MPS).
# Each configuration prints the sweep's two aggregates, from its summary line: particle-steps
# over the sweep's wall time (every run's start-up included: plugins, lattice, the host's first
# triangulation, the CUDA context), and from the first step of any run to the last step of any
# (start-up before the first step and clean-up after the last left out; still counted: runs
# starting late or finishing early, and MPS's second wave). The runs' own rates are printed as a
# distribution; their sum is no aggregate unless every run ran side by side the whole time.
set -u
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
bundle=${1:-}
if [[ -z $bundle ]]; then
  for c in "$here/.." "$here/../bundle" ./bundle; do
    [[ -x $c/bin/pipeline ]] && { bundle=$c; break; }
  done
fi
bin=${PIPELINE_BIN:-$bundle/bin/pipeline}
[[ -x $bin ]] || { echo "sweep_abp: no pipeline at '$bin' (give the bundle folder, or PIPELINE_BIN)" >&2; exit 2; }
pipeline_file=$bundle/pipelines/bench-abp.yaml
[[ -f $pipeline_file ]] || pipeline_file=$here/../pipelines/bench-abp.yaml
out=${OUT:-./sweep-bench-out}
mkdir -p "$out"
work=$(mktemp -d "${TMPDIR:-/tmp}/sweep_abp.XXXXXX")
trap 'rm -rf "$work"' EXIT
steps=${STEPS:-10000}
n=${N:-16384}
device=${DEVICE:-cuda}
report=$out/sweep.txt
sets=(--set "system.N=$n" --set "run.steps=$steps")

{
  echo "sweep_abp: $(date -u +%FT%TZ), $("$bin" --help >/dev/null 2>&1 && echo "$bin")"
  nvidia-smi -L 2>&1 | head -8
  echo "CPU cores: $(nproc); nvidia-cuda-mps-control: $(command -v nvidia-cuda-mps-control || echo 'not found')"
  echo "pipeline: $pipeline_file, N = $n, $steps steps per run"
  echo
  echo "== one run alone: pipeline bench --sizes $n --steps 200 --warmup 20"
} >"$report"
"$bin" bench "$pipeline_file" --device "$device" --sizes "$n" --steps 200 --warmup 20 --results "$work/bench" \
  >>"$report" 2>&1 || echo "(bench failed)" >>"$report"

# config NAME RUNS K [extra sweep flags...]
config() {
  local name=$1 runs=$2 k=$3
  shift 3
  local tag=$name-k$k dir=$work/$name-k$k
  echo >>"$report"
  echo "== $tag: $runs runs, --concurrent $k $*" >>"$report"
  local t0=$(date +%s.%N)
  timeout $((60 + steps / 50)) "$bin" sweep "$pipeline_file" --device "$device" "${sets[@]}" --replicas "$runs" --concurrent "$k" \
    --out "$dir" "$@" >"$work/$tag.log" 2>&1
  local rc=$? t1=$(date +%s.%N)
  grep -E "^sweep: (CUDA MPS|no CUDA MPS|--in-process|[0-9]+ runs? (done|failed))|capped" "$work/$tag.log" >>"$report"
  [[ $rc == 0 ]] || { echo "exit $rc; last lines:" >>"$report"; tail -5 "$work/$tag.log" >>"$report"; }
  if [[ -f $dir/index.csv ]]; then
    cp "$dir/index.csv" "$out/index-$tag.csv"
    # Columns without grid axes: folder,replica,seed,status,exit_code,steps_per_s,...
    awk -F, -v n="$n" -v t0="$t0" -v t1="$t1" 'NR > 1 && $4 == "done" { s += $6; c++; if (min == "" || $6 < min) min = $6; if ($6 > max) max = $6 }
      END { if (c) printf "per run, its first step to its last: mean %.0f steps/s (min %.0f, max %.0f) = %.3g particle-steps/s; %d runs done; wall %.1f s (the command)\n", s / c, min, max, n * s / c, c, t1 - t0 }' \
      "$dir/index.csv" >>"$report"
    # A failed run's reason, once.
    awk -F, 'NR > 1 && $4 != "done" { print "not done: " $0; exit }' "$dir/index.csv" >>"$report"
  fi
  rm -rf "$dir"
}

config alone-processes 8 1
if [[ ${QUICK:-0} == 1 ]]; then  # the largest K only
  config in-process 64 64 --in-process
  config processes-mps 64 64 --mps auto
else
  config processes-no-mps 16 8 --mps off
  config processes-mps 64 8 --mps auto
  config processes-mps 64 64 --mps auto
  config in-process 64 8 --in-process
  config in-process 64 64 --in-process
fi
cat "$report"
