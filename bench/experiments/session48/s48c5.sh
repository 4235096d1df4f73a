#!/bin/bash
# Session 48, call 5: branch pdlwide48 with Lawson's grid rounds launched programmatically too
# (pdll: its delaunay and overlap_correct plugins) against pdlw (call 4's overlap_correct plugin
# alone) and main 2fae18c. The Delaunay stages' CUDA tests on pdll; bench-abp at 2^16, 2^17, 2^18
# and 2^20 and bench-hd07 at 2^16 and 2^18, three interleaved rounds; a CUPTI timeline of
# bench-abp 2^20 on pdll.
#   bash bench/experiments/session48/s48c5.sh gpu-carry/b48.tar.xz   carry: gpu-carry (b48, vpdlw, vpdll)
source tools/gpu/call_lib.sh s48c5 "$1"
declare -A D=([main]=$B)
D[pdlw]=$(variant pdlw gpu-carry/vpdlw.tar.xz)
D[pdll]=$(variant pdll gpu-carry/vpdll.tar.xz)
delaunay_tests pdll
hd07() {
  local v=$1 tag=$2
  timeout 120 "${D[$v]}/bin/pipeline" bench "${D[$v]}/pipelines/bench-hd07.yaml" --device cuda --sizes 65536,262144 \
    --steps 400 --warmup 20 2>&1 | grep -E "^[0-9]|overlap_correct/iter|rror" | sed "s/^/$v $tag: /" >> "$O/hd07.txt"
  step "hd07-$v-$tag" "${PIPESTATUS[0]}"
}
for r in 1 2 3; do
  for v in main pdlw pdll; do
    bench_abp $v r$r --sizes 65536,131072,262144,1048576 --steps 200 --warmup 20
    hd07 $v r$r
  done
done
B0=$B
B=${D[pdll]}
timelines 1048576
for f in "$O"/trace-1048576*; do mv "$f" "${f/trace-1048576/trace-pdll-1048576}"; done
B=$B0
echo done t=$SECONDS >> $I; pack
