#!/usr/bin/env bash
# Device run for overlap_correct tuning (see bench/overlap_correct-PERF.md): tests, bench-abp at
# three sizes, the hard-disk EOS test. Needs a bundle in bundle-perf at the repository root
# (tools/bundle build-perf bundle-perf); run it from anywhere, e.g. bench/overlap_correct-perf_run.sh.
cd "$(dirname "$0")/.." || exit 1
B=bundle-perf
P=$B/pipelines/bench-abp.yaml
nvidia-smi --query-gpu=name,clocks.sm,clocks.mem,temperature.gpu,utilization.gpu --format=csv
for t in test_overlap_correct test_overlap_correct_determinism test_overlap_correct_errors test_overlap_correct_cpu_cuda; do
  [[ -x $B/bin/$t ]] || continue  # a bundle from before test_overlap_correct.cpp was split has the first only
  echo "== $t"; $B/bin/$t 2>&1 | tail -4
done
bench() { local tag=$1; shift; echo "== $tag"; "$@" 2>&1 | grep -E "^[0-9]|overlap_correct/iter|rror"; }
bench default $B/bin/pipeline bench $P --device cuda --sizes 2^16,2^18,2^20 --steps 50 --warmup 10 --results $OUT/default
# (variants: set FF_* switches of an experimental build here and repeat the 2^20 bench)
echo "== eos"; timeout ${EOS_S:-150} $B/bin/test_hard_disk_eos 2>&1 | grep -E "cuda:|cpu:|%|passed|failed" 
