#!/bin/bash
# Session 48, call 7: branch touch48's overlap_correct plugin (on main 06c9f3b): with FF_OC_TOUCH=1
# an edge pass (wide_touch) marks the ends of edges within reach and the wide gather (iteration 0
# above 2^17 particles) takes only those. The correction's six CUDA test executables and its
# error cases with FF_OC_TOUCH=1 (the 150 000-particle cases run the wide path; CPU == CUDA bits),
# then bench-abp and bench-hd07 at 2^17, 2^18 and 2^20 without and with it, three interleaved rounds.
#   bash bench/experiments/session48/s48c7.sh gpu-carry/b48m.tar.xz   carry: gpu-carry (b48m, vtouch)
source tools/gpu/call_lib.sh s48c7 "$1"
declare -A D=([main]=$B)
D[touch]=$(variant touch gpu-carry/vtouch.tar.xz)
export FF_OC_TOUCH=1
TEST_TIMEOUT=120 correction_tests touch
errors_test touch
unset FF_OC_TOUCH
run() {  # run PIPELINE MODE TAG
  if [[ $2 == on ]]; then export FF_OC_TOUCH=1; else unset FF_OC_TOUCH; fi
  timeout 60 "${D[touch]}/bin/pipeline" bench "${D[touch]}/pipelines/$1.yaml" --device cuda --sizes 131072,262144,1048576 \
    --steps 200 --warmup 20 2>&1 | grep -E "^[0-9]|overlap_correct/iter|rror" | sed "s/^/$1 $2 $3: /" >> "$O/ab.txt"
  step "$1-$2-$3" "${PIPESTATUS[0]}"
  unset FF_OC_TOUCH
}
for r in 1 2 3; do
  for m in off on; do run bench-abp $m r$r; run bench-hd07 $m r$r; done
done
echo done t=$SECONDS >> $I; pack
