#!/bin/bash
# Session 49, call 2: call 1's bit comparison again with an initial state that φ = 0.7 allows
# (call 1's runs were refused: random placement jams near 0.547). abp.yaml at N = 2^18, φ = 0.7
# from a triangular lattice sample, 300 steps, on the new bundle (d455681) and main 06c9f3b's;
# h5hash of both outputs.
#   bash bench/experiments/session49/s49c2.sh gpu-carry/b49.tar.xz gpu-carry/b48m.tar.xz
source tools/gpu/call_lib.sh s49c2 "$1"
mkdir -p /tmp/old && tar -xf "$2" -C /tmp/old
declare -A D=([new]=$B [old]=/tmp/old/bundle)
for v in new old; do
  timeout 120 "${D[$v]}/bin/pipeline" run "${D[$v]}/pipelines/abp.yaml" --device cuda --out /tmp/run-$v --force \
    --set system.N=262144 --set system.packing_fraction=0.7 --set system.init=triangular_lattice_sample \
    --set run.steps=300 > "$O/run-$v.txt" 2>&1
  echo "run $v rc=$?" >> "$I"
  "${D[$v]}/bin/h5hash" /tmp/run-$v/abp.h5 > "$O/hash-$v.txt" 2>&1
done
if cmp -s "$O/hash-new.txt" "$O/hash-old.txt" && [ -s "$O/hash-new.txt" ]; then echo "bits: same" >> "$I"; else echo "bits: DIFFER" >> "$I"; fi
grep -h "lawson\|rounds" "$O"/run-new.txt | tail -3 >> "$I"
echo done t=$SECONDS >> $I; pack
