#!/bin/bash
# Session 48, call 2: branch trig48's overlap_correct plugin against main 2fae18c's.
#   trig:    the dense kernel calls allow_next_kernel() after its programmatic wait, so the next
#            step's integrator is scheduled on the SMs it leaves free while it runs
#   trigpre: trig + the next pointers' expected mix sum taken before the wait
# The correction's six CUDA test executables on both, its error cases and the graph-capture,
# rollback and sweep tests on trigpre; bench-abp at 256 ... 16 384 and bench-hd07 at 16 384 and
# 65 536 (the Carter row's pipeline), five interleaved rounds of 400 steps; CUPTI timelines of
# bench-abp 1 024 on main and trigpre.
#   bash bench/experiments/session48/s48c2.sh gpu-carry/b48.tar.xz   carry: gpu-carry (b48, vtrig, vtrigpre)
source tools/gpu/call_lib.sh s48c2 "$1"
declare -A D=([main]=$B)
D[trig]=$(variant trig gpu-carry/vtrig.tar.xz)
D[trigpre]=$(variant trigpre gpu-carry/vtrigpre.tar.xz)
correction_tests trig trigpre
errors_test trigpre
TEST_TIMEOUT=150 variant_tests trigpre test_graph_capture test_rollback test_sweep
ROUNDS=5 rounds "main trig trigpre" --sizes 256,1024,4096,16384 --steps 400 --warmup 20
hd07() {  # bench-hd07 as bench_abp runs bench-abp
  local v=$1 tag=$2
  timeout 120 "${D[$v]}/bin/pipeline" bench "${D[$v]}/pipelines/bench-hd07.yaml" --device cuda --sizes 16384,65536 \
    --steps 400 --warmup 20 2>&1 | grep -E "^[0-9]|overlap_correct/iter|host's own|rror" | sed "s/^/$v $tag: /" >> "$O/hd07.txt"
  step "hd07-$v-$tag" "${PIPESTATUS[0]}"
}
for r in 1 2 3 4 5; do for v in main trig trigpre; do hd07 $v r$r; done; done
B0=$B
for v in main trigpre; do
  B=${D[$v]}
  timelines 1024
  for f in "$O"/trace-1024*; do mv "$f" "${f/trace-1024/trace-$v-1024}"; done
done
B=$B0
echo done t=$SECONDS >> $I; pack
