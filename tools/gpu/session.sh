#!/usr/bin/env bash
# One batched GPU session from a bundle (tools/bundle): the whole test suite, the CUDA
# benchmarks and a CUDA-vs-CPU run of brownian.yaml. Logs go to $OUT (or ./gpu-out).
#   tools/gpu/session.sh BUNDLE_DIR
set -uo pipefail
bundle=${1:-bundle}
out=${OUT:-gpu-out}
mkdir -p "$out"
export PATH="$bundle/bin:$PATH"
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader

echo "== tests"
"$bundle/bin/run-tests" >"$out/tests.log" 2>&1
echo "run-tests exit $?"; grep -E "^(PASS|FAIL)|SKIPPED|passed, " "$out/tests.log" | head -n 40

echo "== device-to-device copy bandwidth"
"$bundle/bin/copy-bandwidth" 1024 | tee "$out/copy_bandwidth.json"

echo "== benchmarks"
res="$out/results"; mkdir -p "$res"  # one folder: JSON lines per pipeline
pipeline bench "$bundle/pipelines/bench-brownian.yaml" --device cuda --sizes 2^20,2^24 --steps 200 --warmup 20 --results "$res" 2>&1 | tee -a "$out/bench.txt"
pipeline bench "$bundle/pipelines/bench-brownian.yaml" --device cuda --sizes 2^20,2^24 --steps 200 --warmup 20 --set run.precision=float --results "$res" 2>&1 | tee -a "$out/bench.txt"
pipeline bench "$bundle/pipelines/bench-noop.yaml" --device cuda --steps 20000 --warmup 1000 --results "$res" 2>&1 | tee -a "$out/bench.txt"
pipeline bench "$bundle/pipelines/bench-noop-fork.yaml" --device cuda --steps 20000 --warmup 1000 --results "$res" 2>&1 | tee -a "$out/bench.txt"
# Extra commands (a file of shell lines) for this session: EXTRA=file tools/gpu/session.sh ...
if [[ -n ${EXTRA:-} && -f $EXTRA ]]; then B=$bundle OUT=$out bash "$EXTRA"; fi

echo "== brownian.yaml on cuda and cpu: same H5MD layout"
rm -rf "$out/run_cuda" "$out/run_cpu"
pipeline run "$bundle/pipelines/brownian.yaml" --device cuda --out /tmp/run_cuda 2>&1 | tail -n 3
pipeline run "$bundle/pipelines/brownian.yaml" --device cpu --out /tmp/run_cpu 2>&1 | tail -n 3
python3 - <<'PY' 2>&1 | tee "$out/h5md_layout.txt"
import subprocess, sys
try:
    import h5py
except ImportError:
    # No h5py on the GPU machine: compare layouts with h5ls if present, else by file size only.
    import os
    for d in ("/tmp/run_cuda", "/tmp/run_cpu"):
        print(d, os.path.getsize(d + "/trajectory.h5"), "bytes")
    sys.exit(0)
def layout(p):
    out = []
    h5py.File(p, "r").visititems(lambda n, o: out.append((n, getattr(o, "shape", None))))
    return out
a, b = layout("/tmp/run_cuda/trajectory.h5"), layout("/tmp/run_cpu/trajectory.h5")
print("same layout:", a == b, len(a), "objects")
PY
# Few files come back from a device run: pack the JSON lines into one archive.
tar -C "$out" -cf "$out/results.tar" results && rm -rf "$out/results"
