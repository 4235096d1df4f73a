#!/bin/bash
# Issue 19's demonstration on a GPU node, from a bundle (tools/bundle):
#  (a) a long ABP run (pipelines/abp.yaml, observe.h5md writing frames) run once, uninterrupted;
#  (b) the same run interrupted three times: SIGTERM mid-run (exit 3, a checkpoint) then
#      --resume; SIGKILL at a random step then --resume; a resume to a smaller run.steps, which
#      finishes, then --resume --set run.steps=<full> extending it;
#  (c) the SHA-256 of every dataset of both H5MD files (bin/h5hash; /parameters and /h5md, which
#      record the commit, the time and the resume history, left out), and IDENTICAL or DIFFERENT;
#  (d) the cost of a checkpoint of bench-abp at 2^20: ms per checkpoint and MB per file, as the
#      runs report them (runs with and without four checkpoints, interleaved);
#  (e) the cost of the per-step non-finite check of the overdamped integrators: bench-abp at
#      2^14 and 2^20, and abp.integrate alone at 2^20 (a replayed CUDA graph: the check's upper
#      bound), with the bundle's plugins and with WITHOUT, a folder of the two plugin libraries
#      built without the check (tools/bench/plugin_ab.sh, interleaved). Make WITHOUT from
#      bench/checkpoint-without-check.patch: apply it in a worktree, build the targets
#      flipflow_plugin_abp and flipflow_stage_overdamped, copy their two .so files into
#      BUNDLE/i19-without/ and `patchelf --force-rpath --set-rpath '$ORIGIN/../lib'` them.
#
#   OUT=dir bench/checkpoint_demo.sh [BUNDLE=bundle]
#
# Logs and hash lists go to $OUT (default ./checkpoint-demo-out), run outputs to $WORK (default a
# fresh folder under ${TMPDIR:-/tmp}; removed at the end unless KEEP=1). Environment (defaults for
# an H100, about 4 minutes in all): DEVICE (cuda when nvidia-smi sees a GPU, else cpu), N (65536),
# STEPS (100000), FRAME_EVERY (STEPS/50), CKPT_EVERY (STEPS/20), BIG_N (1048576), BIG_STEPS (400),
# AB_SIZES (2^14,2^20), AB_STEPS (300), AB_ROUNDS (3), AB_FREE_SIZE (2^20), AB_FREE_STEPS (2000),
# AB_FREE_WARMUP (200), WITHOUT (default $BUNDLE/i19-without;
# part (e) is skipped when it is missing), PARTS (which of a b d e to run; default "a b d e",
# (c) comes with a and b). Exit 0 when the two files are IDENTICAL, 1 otherwise. On a CPU, in
# seconds: PARTS="a b" N=1024 STEPS=4000 bench/checkpoint_demo.sh build-bundle (or BIG_N=16384
# BIG_STEPS=40 AB_SIZES=2^10,2^12 AB_FREE_SIZE=2^14 for d and e too).
set -uo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
bundle=$(cd "${1:-bundle}" && pwd) || { echo "checkpoint_demo: no bundle folder '${1:-bundle}'" >&2; exit 2; }
bin=$bundle/bin/pipeline
h5hash=$bundle/bin/h5hash
pipelines=$bundle/pipelines
for f in "$bin" "$h5hash"; do [[ -x $f ]] || { echo "checkpoint_demo: $f missing (rebuild the bundle)" >&2; exit 2; }; done
out=${OUT:-checkpoint-demo-out}
mkdir -p "$out"
out=$(cd "$out" && pwd)
work=${WORK:-$(mktemp -d "${TMPDIR:-/tmp}/checkpoint-demo.XXXXXX")}
mkdir -p "$work"
[[ ${KEEP:-0} == 1 ]] || trap 'rm -rf "$work"' EXIT
device=${DEVICE:-}
if [[ -z $device ]]; then
  if command -v nvidia-smi >/dev/null && nvidia-smi -L >/dev/null 2>&1; then device=cuda; else device=cpu; fi
fi
parts=" ${PARTS:-a b d e} "
n=${N:-65536}
steps=${STEPS:-100000}
frame_every=${FRAME_EVERY:-$((steps / 50))}
ckpt_every=${CKPT_EVERY:-$((steps / 20))}
log=$out/demo.log
say() { echo "$*" | tee -a "$log"; }
now() { date +%s.%N; }
calc() { awk "BEGIN { printf \"%.${2:-2}f\", $1 }"; }  # calc EXPR [DECIMALS] (no bc on some nodes)
: >"$log"
say "checkpoint_demo: $(cat "$bundle/.flipflow-bundle" 2>/dev/null | head -n 1)"
[[ $device == cuda ]] && say "device: $(nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | head -n 1)"
say "abp.yaml: N = $n, $steps steps, a frame every $frame_every steps, on $device; work in $work"

# The run of (a) and (b): abp.yaml with its observers every frame_every steps.
sets=(--set "system.N=$n" --set "step.observe.h5md.every=$frame_every" --set "step.observe.msd.every=$frame_every"
      --set "step.observe.progress.every=$((steps / 10))")
run() {  # run DIR LOGNAME [ARGS...]: pipeline run abp.yaml in the foreground, its exit code
  local dir=$1 name=$2
  shift 2
  "$bin" run "$pipelines/abp.yaml" "${sets[@]}" --device "$device" --out "$dir" "$@" >"$out/$name.log" 2>&1
}
newest_checkpoint() {  # the step of the newest checkpoint in DIR (0: none)
  local last
  last=$(ls "$1" 2>/dev/null | sed -n 's/^checkpoint-0*\([0-9][0-9]*\)\.h5$/\1/p' | sort -n | tail -n 1)
  echo "${last:-0}"
}
wait_for_checkpoint() {  # wait_for_checkpoint DIR STEP PID: until a checkpoint at >= STEP, or PID ended
  while (($(newest_checkpoint "$1") < $2)); do
    kill -0 "$3" 2>/dev/null || return 1
    sleep 0.05
  done
}
fail() { say "checkpoint_demo: FAILED: $*"; exit 1; }
# random_moment PID DIR STEP: waits for the checkpoints at STEP - ckpt_every and at STEP, then for
# a random 0-89 % of the time between them (a random step before the next checkpoint, whatever the
# machine's speed); prints that delay in ms. Fails when PID ended first.
random_moment() {
  local t1 t2 ms
  wait_for_checkpoint "$2" $(($3 - ckpt_every)) "$1" || return 1
  t1=$(now)
  wait_for_checkpoint "$2" "$3" "$1" || return 1
  t2=$(now)
  ms=$(calc "($t2 - $t1) * 1000 * $((RANDOM % 90)) / 100" 0)
  sleep "$(calc "$ms / 1000" 3)"
  echo "$ms"
}

one=$work/uninterrupted
two=$work/interrupted
if [[ $parts == *" a "* ]]; then
  say "== (a) uninterrupted: $steps steps"
  t0=$(now)
  run "$one" a-uninterrupted --set "run.steps=$steps" || fail "the uninterrupted run (log $out/a-uninterrupted.log)"
  say "   $(tail -n 1 "$out/a-uninterrupted.log")"
  say "   wall $(calc "$(now) - $t0" 1) s"
fi

if [[ $parts == *" b "* ]]; then
  ckpt=(--set "run.checkpoint={every: $ckpt_every, keep: 2}")
  say "== (b) interrupted three times, checkpoints every $ckpt_every steps"
  t0=$(now)
  # 1. SIGTERM at a random step after a fifth of the run.
  first=$(((steps / 5 + ckpt_every - 1) / ckpt_every * ckpt_every))
  "$bin" run "$pipelines/abp.yaml" "${sets[@]}" --device "$device" --out "$two" --set "run.steps=$steps" "${ckpt[@]}" \
    >"$out/b1-sigterm.log" 2>&1 &
  pid=$!
  delay=$(random_moment "$pid" "$two" "$first") || fail "run 1 ended before its checkpoint at step $first"
  kill -TERM "$pid"
  wait "$pid"
  rc=$?
  ((rc == 3)) || fail "run 1: exit $rc after SIGTERM, expected 3 (log $out/b1-sigterm.log)"
  say "   1. SIGTERM ${delay} ms after the checkpoint at step $first: exit $rc;" \
    "$(grep -o 'stopped by SIGTERM after step [0-9]*' "$out/b1-sigterm.log")"
  # 2. --resume, SIGKILL at a random step past the middle of the run.
  "$bin" run "$pipelines/abp.yaml" "${sets[@]}" --device "$device" --out "$two" --set "run.steps=$steps" "${ckpt[@]}" \
    --resume >"$out/b2-sigkill.log" 2>&1 &
  pid=$!
  half=$(((steps / 2 + ckpt_every - 1) / ckpt_every * ckpt_every))
  delay=$(random_moment "$pid" "$two" "$half") || fail "run 2 ended before its checkpoint at step $half"
  kill -KILL "$pid"
  wait "$pid" 2>/dev/null
  rc=$?
  ((rc == 137)) || fail "run 2: exit $rc, expected 137 (killed; log $out/b2-sigkill.log)"
  at=$(newest_checkpoint "$two")
  say "   2. --resume ($(grep -o 'resuming[^;]*' "$out/b2-sigkill.log" | head -n 1)), SIGKILL ${delay} ms after" \
    "the checkpoint at step $half; newest checkpoint: step $at"
  # 3. --resume to a smaller run.steps: the run finishes there (exit 0) ...
  short=$((steps * 3 / 4))
  ((short > at)) || short=$((at + ckpt_every))
  ((short < steps)) || fail "no room for a shorter run after step $at"
  run "$two" b3-short --set "run.steps=$short" "${ckpt[@]}" --resume || fail "run 3 (log $out/b3-short.log)"
  say "   3. --resume --set run.steps=$short: $(tail -n 1 "$out/b3-short.log")"
  # 4. ... and is extended to the full length.
  run "$two" b4-extend --set "run.steps=$steps" "${ckpt[@]}" --resume || fail "run 4 (log $out/b4-extend.log)"
  say "   4. --resume --set run.steps=$steps: $(tail -n 1 "$out/b4-extend.log")"
  say "   wall $(calc "$(now) - $t0" 1) s (four processes)"
fi

if [[ $parts == *" a "* && $parts == *" b "* ]]; then
  say "== (c) SHA-256 of every dataset of abp.h5 (not /parameters, /h5md)"
  "$h5hash" "$one/abp.h5" >"$out/hashes-uninterrupted.txt" || fail "h5hash of the uninterrupted run"
  "$h5hash" "$two/abp.h5" >"$out/hashes-interrupted.txt" || fail "h5hash of the interrupted run"
  tee -a "$log" <"$out/hashes-uninterrupted.txt" | sed 's/^/   /'
  frames=$(awk '$2 == "/particles/all/position/value" {print $3}' "$out/hashes-uninterrupted.txt")
  say "   $(wc -l <"$out/hashes-uninterrupted.txt") datasets; position frames: $frames"
  if cmp -s "$out/hashes-uninterrupted.txt" "$out/hashes-interrupted.txt"; then
    say "   uninterrupted vs interrupted three times: IDENTICAL"
    identical=1
  else
    say "   uninterrupted vs interrupted three times: DIFFERENT"
    diff "$out/hashes-uninterrupted.txt" "$out/hashes-interrupted.txt" | tee -a "$log"
    identical=0
  fi
fi

if [[ $parts == *" d "* ]]; then
  big_n=${BIG_N:-1048576}
  big_steps=${BIG_STEPS:-400}
  every=$((big_steps / 4))
  say "== (d) checkpoint cost: bench-abp.yaml, N = $big_n, $big_steps steps, a checkpoint every $every (4 in all)"
  # The run's own account ("checkpoints K (X MB, Y ms each)" on its done line: write() from the
  # device idle to the file renamed), and the run's wall time with and without, interleaved (a
  # whole 2^20 run's start-up varies by about a second: the difference is only a bound).
  for round in 1 2; do
    for variant in without with; do
      dir=$work/d-$variant-$round
      extra=()
      [[ $variant == with ]] && extra=(--set "run.checkpoint={every: $every, keep: 1}")
      t0=$(now)
      "$bin" run "$pipelines/bench-abp.yaml" --set "system.N=$big_n" --set "run.steps=$big_steps" "${extra[@]}" \
        --device "$device" --out "$dir" >"$out/d-$variant-$round.log" 2>&1 || fail "(d) $variant (log $out/d-$variant-$round.log)"
      t=$(calc "$(now) - $t0" 3)
      say "   round $round, $variant: $t s; $(grep -o 'checkpoints [0-9]* ([^)]*)' "$out/d-$variant-$round.log" || echo 'no checkpoints')"
      rm -rf "$dir"
    done
  done
fi

if [[ $parts == *" e "* ]]; then
  without=${WITHOUT:-$bundle/i19-without}
  if [[ ! -d $without ]]; then
    say "== (e) skipped: no folder $without of plugins built without the check"
  else
    say "== (e) the non-finite check: the bundle's plugins (-) vs $without, interleaved"
    ab=$here/../tools/bench/plugin_ab.sh
    PIPELINE_BIN=$bin DEVICE=$device SIZES=${AB_SIZES:-2^14,2^20} STEPS=${AB_STEPS:-300} ROUNDS=${AB_ROUNDS:-3} \
      SHOW='^no metric lines$' "$ab" "$pipelines/bench-abp.yaml" - "$without" 2>&1 | tee -a "$log" | tee "$out/e-bench-abp.txt"
    cat >"$work/abp-free.yaml" <<'YAML'
# abp.integrate alone (no excluded volume): on CUDA the step is a replayed graph of one kernel,
# where the check's share of the step is the largest.
system: {dimensions: 2, N: 1048576, packing_fraction: 0.4, sigma: 1.0, init: random}
run: {steps: 1000, dt: 0.01, seed: 1, precision: double}
plugins: [abp]
step:
  - {stage: abp.integrate, v0: 1.0, Dr: 0.05, D: 0.01}
YAML
    PIPELINE_BIN=$bin DEVICE=$device SIZES=${AB_FREE_SIZE:-2^20} STEPS=${AB_FREE_STEPS:-2000} \
      WARMUP=${AB_FREE_WARMUP:-200} ROUNDS=${AB_ROUNDS:-3} \
      SHOW='^no metric lines$' "$ab" "$work/abp-free.yaml" - "$without" 2>&1 | tee -a "$log" | tee "$out/e-abp-free.txt"
  fi
fi
say "checkpoint_demo: done"
[[ ${identical:-1} == 1 ]]
