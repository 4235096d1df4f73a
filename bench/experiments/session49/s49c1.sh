#!/bin/bash
# Session 49, call 1: one programmatic element loop in the backend (core/backend/cuda/loop.cuh's
# after_previous_kernel, used by the overdamped integrators and Lawson's grid rounds instead of two
# copies). The whole CUDA suite on the new bundle; the same bits as main 06c9f3b's bundle
# (h5hash of abp.yaml at N = 2^18, φ = 0.7, 300 steps: Lawson's grid rounds and the integrator);
# bench-abp interleaved against the old bundle (no speed change expected); and the steady-state
# rows (200 steps after 300 warm-up steps, where the correction's cost has stopped growing).
#   bash bench/experiments/session49/s49c1.sh gpu-carry/b49.tar.xz gpu-carry/b48m.tar.xz
source tools/gpu/call_lib.sh s49c1 "$1"
mkdir -p /tmp/old && tar -xf "$2" -C /tmp/old
declare -A D=([new]=$B [old]=/tmp/old/bundle)
suite "$B" 250
step suite 0
for v in new old; do
  timeout 120 "${D[$v]}/bin/pipeline" run "${D[$v]}/pipelines/abp.yaml" --device cuda --out /tmp/run-$v --force \
    --set system.N=262144 --set system.packing_fraction=0.7 --set run.steps=300 > "$O/run-$v.txt" 2>&1
  echo "run $v rc=$?" >> "$I"
  "${D[$v]}/bin/h5hash" /tmp/run-$v/abp.h5 > "$O/hash-$v.txt" 2>&1
done
if cmp -s "$O/hash-new.txt" "$O/hash-old.txt" && [ -s "$O/hash-new.txt" ]; then echo "bits: same" >> "$I"; else echo "bits: DIFFER" >> "$I"; fi
step bits 0
ROUNDS=3 rounds "new old" --sizes 1024,16384,1048576 --steps 200 --warmup 20
bench_abp new steady --sizes 1024,16384 --steps 200 --warmup 300
bench_abp old steady --sizes 1024,16384 --steps 200 --warmup 300
echo done t=$SECONDS >> $I; pack
