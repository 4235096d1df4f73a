#!/bin/bash
# Compare plugin builds on one machine, interleaved: `pipeline bench` of one pipeline with each
# plugin folder in turn (through FLIPFLOW_PLUGIN_PATH, which the loader searches before the
# build's own plugins/), for ROUNDS rounds, so that every variant sees the same machine state.
# This is how the variants in bench/overlap_correct-PERF.md were measured on the GPU node.
#
#   tools/bench/plugin_ab.sh PIPELINE.yaml DIR [DIR ...]
#
# DIR: a folder holding the plugin libraries to try (only the ones that differ: the others come
# from the build's plugins/), or - for the build's own plugins. Build a variant, copy its .so to a
# folder (in a bundle, give it the bundle's rpath: patchelf --force-rpath --set-rpath
# '$ORIGIN/../lib'), then list the folders here.
# (Variants of one stage timed in one process, on the same states each step: make_ab_plugin.sh.)
#
# Environment: PIPELINE_BIN (default: bin/pipeline next to this tree's build/, else bundle/),
# DEVICE (cuda when a GPU is visible, else cpu), SIZES (default 2^16,2^20), STEPS (100), WARMUP
# (20), ROUNDS (2), SHOW (an extended regex of the bench's metric lines to print besides the
# table rows; default "iterations per|flips per"). Prints, per round and folder, the bench's rows
# (N, median ms per step, steps/s, ..., ms per stage) and the chosen metric lines.
set -euo pipefail
die() { echo "plugin_ab: error: $*" >&2; exit 1; }
(($# >= 2)) || die "usage: tools/bench/plugin_ab.sh PIPELINE.yaml DIR [DIR ...] (DIR - : the build's own plugins)"
pipeline_file=$1
shift
[[ -f $pipeline_file ]] || die "pipeline file '$pipeline_file' does not exist"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
bin=${PIPELINE_BIN:-}
if [[ -z $bin ]]; then
  for c in "$root/build/bin/pipeline" "$root/bundle/bin/pipeline"; do
    [[ -x $c ]] && { bin=$c; break; }
  done
fi
[[ -n $bin && -x $bin ]] || die "no pipeline executable (build first, or set PIPELINE_BIN)"
for d in "$@"; do
  [[ $d == - || -d $d ]] || die "plugin folder '$d' does not exist"
done
device=${DEVICE:-}
if [[ -z $device ]]; then
  if command -v nvidia-smi >/dev/null && nvidia-smi -L >/dev/null 2>&1; then device=cuda; else device=cpu; fi
fi
show=${SHOW:-iterations per|flips per}
results=$(mktemp -d "${TMPDIR:-/tmp}/plugin_ab.XXXXXX")
trap 'rm -rf "$results"' EXIT

echo "plugin_ab: $pipeline_file on $device, sizes ${SIZES:-2^16,2^20}, ${STEPS:-100} steps after ${WARMUP:-20}, ${ROUNDS:-2} round(s)"
for ((r = 1; r <= ${ROUNDS:-2}; ++r)); do
  for d in "$@"; do
    echo "== round $r: ${d/#-/the build\'s plugins}"
    if [[ $d == - ]]; then unset FLIPFLOW_PLUGIN_PATH; else export FLIPFLOW_PLUGIN_PATH=$(cd "$d" && pwd); fi
    "$bin" bench "$pipeline_file" --device "$device" --sizes "${SIZES:-2^16,2^20}" --steps "${STEPS:-100}" \
      --warmup "${WARMUP:-20}" --results "$results" > "$results/out.txt" 2>&1 ||
      { cat "$results/out.txt" >&2; die "bench failed with $d"; }
    grep -E "^[0-9]|$show" "$results/out.txt" || true
  done
done
