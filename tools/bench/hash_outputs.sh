#!/bin/bash
# A refactor's bit-identity check: runs every shipped pipeline (pipelines/*.yaml) on the CPU at a
# small size with a checkpoint at its last step, and prints the SHA-256 of every output: every
# dataset of every H5MD file (tools/h5hash; /parameters and /h5md left out: they record the
# commit and the time), every CSV and the checkpoint's fields, clock, Δt controller, counters and
# stage states (its meta/ and pipeline/ groups record the commit). Run it before and after a
# change and diff the two listings.
#
#   tools/bench/hash_outputs.sh [LISTING]       (default: stdout)
#
# Environment: PIPELINE_BIN, H5HASH (default: build/bin/{pipeline,h5hash}), N (512), STEPS (1000),
# DEVICE (cpu), THREADS (2), ONLY (an extended regex of pipeline names to run; default all).
set -uo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
bin=${PIPELINE_BIN:-$root/build/bin/pipeline}
h5hash=${H5HASH:-$(dirname "$bin")/h5hash}
[[ -x $bin && -x $h5hash ]] || { echo "hash_outputs: need $bin and $h5hash (build them)" >&2; exit 1; }
n=${N:-512}
steps=${STEPS:-1000}
work=$(mktemp -d "${TMPDIR:-/tmp}/hash_outputs.XXXXXX")
trap 'rm -rf "$work"' EXIT
listing=${1:-/dev/stdout}
{
  echo "# hash_outputs: N=$n, $steps steps, ${DEVICE:-cpu}, $(basename "$bin")"
  for f in "$root"/pipelines/*.yaml; do
    name=$(basename "$f" .yaml)
    [[ -n ${ONLY:-} && ! $name =~ ${ONLY} ]] && continue
    out=$work/$name
    if ! "$bin" run "$f" --set system.N="$n" --set run.steps="$steps" --set "run.checkpoint={every: $steps}" \
      --device "${DEVICE:-cpu}" --threads "${THREADS:-2}" --out "$out" >"$work/$name.log" 2>&1; then
      echo "== $name: FAILED: $(tail -n 1 "$work/$name.log")"
      continue
    fi
    echo "== $name"
    (cd "$out" && find . -type f | LC_ALL=C sort) | while read -r file; do
      file=${file#./}
      case $file in
        checkpoint-*.h5) "$h5hash" "$out/$file" | grep -Ev '  /(meta|pipeline)/' | sed "s|^|$file |" ;;
        *.h5) "$h5hash" "$out/$file" | sed "s|^|$file |" ;;
        *) echo "$file $(sha256sum <"$out/$file" | cut -d' ' -f1)" ;;
      esac
    done
  done
} >"$listing"
