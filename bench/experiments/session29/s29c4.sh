#!/bin/bash
# Session 29, call 4: branch fin29 (on pm29: the cap tested on |d|², take moves a particle from
# the position its gather read) as a whole bundle: every CUDA test; bench-abp against pm29's
# overlap_correct plugin in the same bundle, three interleaved rounds at 2^10..2^16, both at 2^20
# (200 after 20, 100 after 3 000); the 64-run sweep row on both; Carter side by side on fin29.
#   rm -rf bundle && tools/bundle build bundle (on fin29) && tar -cf - bundle | gzip -5 > gpu-carry/b29fin.tar.gz
#   v29pm: pm29's plugin from gpu-carry/b29pm.tar.gz
#   bash bench/experiments/session29/s29c4.sh gpu-carry/b29fin.tar.gz   carry: the bundle, v29pm, peers-bundle.tar.gz
source tools/gpu/call_lib.sh c4 "$1"
tar -xzf gpu-carry/v29pm.tgz -C /tmp
declare -A D=([fin]=$B [pm]=$(shadow pm /tmp/v29pm))
for v in pm fin fin pm pm fin; do bench_abp $v ab --sizes 1024,4096,16384,65536 --steps 200 --warmup 20; done
suite $B
step suite 0
for v in pm fin; do bench_abp $v big --sizes 1048576 --steps 200 --warmup 20; done
for v in fin pm; do bench_abp $v late --sizes 1048576 --steps 100 --warmup 3000; done
sweep_one() {  # sweep_one V TAG: sweep_abp's run on the bundle ${D[V]}
  rm -rf /tmp/sw
  timeout 60 "${D[$1]}/bin/pipeline" sweep "${D[$1]}/pipelines/bench-abp.yaml" --device cuda --set system.N=16384 \
    --set run.steps=5000 --replicas 64 --out /tmp/sw --concurrent 64 --in-process 2>&1 | tail -1 |
    sed "s/^/sweep $1 $2: /" >> "$O/sweep.txt"
  step "sweep-$1-$2" "${PIPESTATUS[0]}"
}
for r in 1 2; do sweep_one fin $r; sweep_one pm $r; done
mkdir -p /tmp/pb && tar -xzf gpu-carry/peers-bundle.tar.gz -C /tmp/pb
((SECONDS < 500)) && { timeout $((575 - SECONDS)) bash bench/carter_side_by_side.sh $B /tmp/pb/bundle $O/carter small > $O/carter-run.txt 2>&1; step carter $?; }
echo done t=$SECONDS >> $I; pack
