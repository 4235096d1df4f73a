#!/bin/bash
# Session 48, call 4: branch pdlwide48's overlap_correct plugin against main 2fae18c's: the wide
# kernels (a full grid's first iteration, 2^17 particles and up) launched programmatically, each
# waiting for the kernel before it. The correction's six CUDA test executables and its error
# cases; bench-abp at 2^17, 2^18 and 2^20 and bench-hd07 at 2^18 (the Carter row's largest size),
# three interleaved rounds; bench-abp 2^20 after 3 000 steps, one round each; CUPTI timelines of
# bench-abp 2^20 on both.
#   bash bench/experiments/session48/s48c4.sh gpu-carry/b48.tar.xz   carry: gpu-carry (b48, vpdlw)
source tools/gpu/call_lib.sh s48c4 "$1"
declare -A D=([main]=$B)
D[pdlw]=$(variant pdlw gpu-carry/vpdlw.tar.xz)
correction_tests pdlw
errors_test pdlw
hd07() {
  local v=$1 tag=$2
  timeout 120 "${D[$v]}/bin/pipeline" bench "${D[$v]}/pipelines/bench-hd07.yaml" --device cuda --sizes 262144 \
    --steps 400 --warmup 20 2>&1 | grep -E "^[0-9]|overlap_correct/iter|rror" | sed "s/^/$v $tag: /" >> "$O/hd07.txt"
  step "hd07-$v-$tag" "${PIPESTATUS[0]}"
}
for r in 1 2 3; do
  for v in main pdlw; do
    bench_abp $v r$r --sizes 131072,262144,1048576 --steps 200 --warmup 20
    hd07 $v r$r
  done
done
for v in main pdlw; do bench_abp $v late --sizes 1048576 --steps 100 --warmup 3000; done
B0=$B
for v in main pdlw; do
  B=${D[$v]}
  timelines 1048576
  for f in "$O"/trace-1048576*; do mv "$f" "${f/trace-1048576/trace-$v-1048576}"; done
done
B=$B0
echo done t=$SECONDS >> $I; pack
