#!/usr/bin/env bash
# Several GPUs for one simulation (issue 21, item 1): checks and timings of the long-range
# phoretic pipeline (pipelines/phoretic-c0.yaml: all-pairs forces split by target over the
# GPUs, velocities all-gathered through NCCL, the Delaunay stages run on every GPU) on 1, 2 and
# 4 GPUs, as many as `nvidia-smi -L` lists. About 3 minutes on H100/H200s; every command has a
# time limit and the script skips what would not fit.
#
#   bench/multi_gpu_phoretic.sh BUNDLE OUT
#
# BUNDLE: a tools/bundle of a CUDA build (bin/pipeline, bin/h5hash, bin/test_team,
# bin/test_phoretic_forces, plugins/, test-plugins/). NCCL is the machine's own: flipflow opens
# libnccl.so.2 at run time (FLIPFLOW_NCCL_LIBRARY, else the loader's search path, else the CUDA
# library folders); this script looks for it and sets FLIPFLOW_NCCL_LIBRARY when the loader
# would not find it. OUT gets log.txt (everything), summary.txt (the table) and results/*.jsonl.
set -uo pipefail
(($# == 2)) || { echo "usage: $0 BUNDLE OUT" >&2; exit 2; }
bundle=$(cd "$1" && pwd) || exit 2
mkdir -p "$2" && out=$(cd "$2" && pwd) || exit 2
exec > >(tee -a "$out/log.txt") 2>&1
start=$SECONDS
budget=170  # seconds: later steps are skipped past this
left() { echo $((budget - (SECONDS - start))); }
P=$bundle/bin/pipeline
pipe=$bundle/pipelines/phoretic-c0.yaml

echo "== $(date -u +%FT%TZ) bundle $(cat "$bundle/.flipflow-bundle" 2>/dev/null)"
gpus=$(nvidia-smi -L 2>/dev/null | grep -c '^GPU ')
echo "== GPUs: $gpus"
nvidia-smi -L
nvidia-smi topo -m 2>/dev/null | head -12
((gpus >= 1)) || { echo "no GPU: nothing to run"; exit 1; }

# NCCL: the machine's libnccl.so.2.
if [[ -z ${FLIPFLOW_NCCL_LIBRARY:-} ]] && ! ldconfig -p 2>/dev/null | grep -q 'libnccl\.so\.2 '; then
  for d in ${CUDA_HOME:+$CUDA_HOME/lib64} /usr/local/cuda/lib64 /usr/local/cuda/lib /usr/lib/x86_64-linux-gnu \
    /usr/local/cuda-*/lib64 /usr/local/cuda-*/targets/x86_64-linux/lib \
    $(python3 -c 'import nvidia.nccl, os; print(os.path.dirname(nvidia.nccl.__file__) + "/lib")' 2>/dev/null); do
    if [[ -f $d/libnccl.so.2 ]]; then
      export FLIPFLOW_NCCL_LIBRARY=$d/libnccl.so.2
      break
    fi
  done
fi
echo "== NCCL: ${FLIPFLOW_NCCL_LIBRARY:-libnccl.so.2 through the loader} ($(ldconfig -p 2>/dev/null | grep -m1 'libnccl\.so\.2 ' || true))"
export NCCL_NVLS_ENABLE=0  # never NVLink multicast (flipflow sets it too)
export NCCL_DEBUG=${NCCL_DEBUG:-WARN}

counts=(1)
((gpus >= 2)) && counts+=(2)
((gpus >= 4)) && counts+=(4)

# 1. Tests: the communicators and 2/4 GPUs = 1 GPU bit for bit (test_team), the forces stage.
echo "== tests"
timeout 100 "$bundle/bin/run-tests" test_team test_phoretic_forces

# 2. `pipeline run --gpus G`: rank 0's H5MD file and checkpoint equal one GPU's (h5hash of every
#    dataset but /parameters, which records the device and the ranks).
echo "== pipeline run --gpus G, N = 16384, 200 steps, double: outputs against one GPU"
for g in "${counts[@]}"; do
  (($(left) > 100)) || { echo "skipped (time)"; break; }
  timeout 60 "$P" run "$pipe" --device cuda --gpus "$g" --set system.N=16384 --set run.steps=200 \
    --set 'run.checkpoint={every: 100}' --out "$out/run-g$g" --force 2>&1 | tail -3
  "$bundle/bin/h5hash" "$out/run-g$g/phoretic-c0.h5" | grep -v ' /parameters' | awk '{print $1, $2}' >"$out/run-g$g.hash"
  if ((g > 1)); then
    if cmp -s "$out/run-g1.hash" "$out/run-g$g.hash"; then echo "  $g GPUs: outputs IDENTICAL to 1 GPU ($(wc -l <"$out/run-g$g.hash") datasets)"
    else echo "  $g GPUs: outputs DIFFER from 1 GPU:"; diff "$out/run-g1.hash" "$out/run-g$g.hash" | head -8; fi
  fi
done

# 3. Timings (pipeline bench, compute stages only): float and double (the pipeline's own), 2^18
#    and 2^20, on 1, 2, 4 GPUs. Steps per pass: each bench does 1 warm-up step + 3 passes of S.
echo "== pipeline bench --gpus G"
bench() {  # bench PRECISION SIZE STEPS G
  local need=$5
  (($(left) > need)) || { echo "skipped $1 $2 on $4 GPUs (time: $(left) s left, needs ~$need)"; return; }
  timeout 110 "$P" bench "$pipe" --device cuda --gpus "$4" --set run.precision="$1" --sizes "$2" --steps "$3" \
    --warmup 1 --results "$out/results-$1" 2>&1 | grep -Ev 'per step: ' | tail -8
}
for g in "${counts[@]}"; do bench float 2^18 10 "$g" 15; done
for g in "${counts[@]}"; do bench float 2^20 3 "$g" 25; done
for g in "${counts[@]}"; do bench double 2^18 4 "$g" 15; done
for g in 1 4 2; do  # one GPU first (the baseline), then 4: the 1-GPU double run at 2^20 is the longest (~7 x 3 s)
  [[ " ${counts[*]} " == *" $g "* ]] && bench double 2^20 2 "$g" 35
done

# 4. The table: step time (median of the latency pass), speed-up over one GPU, communication.
echo "== summary ($((SECONDS - start)) s)"
python3 - "$out" <<'EOF' | tee "$out/summary.txt"
import glob, json, sys
rows = {}
for f in glob.glob(sys.argv[1] + "/results-*/*.jsonl"):
    prec = f.split("/results-")[1].split("/")[0]
    for line in open(f):
        r = json.loads(line)
        rows[(prec, r["N"], r.get("ranks", 1))] = r
print("precision  N        GPUs  ms/step (median)  steps/s   speed-up  phoretic.forces ms  communication ms/step per rank (share)")
for (prec, n, g) in sorted(rows):
    r = rows[(prec, n, g)]
    one = rows.get((prec, n, 1))
    up = one["median_ms"] / r["median_ms"] if one else float("nan")
    comm = " ".join("%.2f(%.1f%%)" % (k["comm_ms"], 100 * k["comm_share"]) for k in r.get("per_rank", []))
    print("%-9s  %-7d  %-4d  %-16.2f  %-8.3f  %-8.2f  %-18.2f  %s" % (prec, n, g, r["median_ms"], r["steps_per_s"], up,
          r["stage_ms"].get("phoretic.forces", float("nan")), comm))
EOF
echo "== done in $((SECONDS - start)) s"
