#!/bin/bash
# Session 50, call 4: branch gather50w (gather50clk + a warp none of whose particles or their neighbours
# moved in the last iteration skips its gathers): its clocks by iteration at 1 024 / 256 particles, and bench-abp
# against main and gather50clk, three interleaved rounds.
#   bash bench/experiments/session50/s50c4.sh gpu-carry/b49f.tar.xz   carry: gpu-carry/b49f.tar.xz, gpu-carry/vgw.tar.xz, gpu-carry/vgclk.tar.xz
source tools/gpu/call_lib.sh s50c4 "$1"
declare -A D=([main]=$B)
D[gw]=$(variant gw gpu-carry/vgw.tar.xz)
D[gclk]=$(variant gclk gpu-carry/vgclk.tar.xz)
for n in 1024 256; do
  FF_GCLK=1 timeout 100 "${D[gw]}/bin/pipeline" bench "${D[gw]}/pipelines/bench-abp.yaml" --device cuda --sizes $n \
    --steps 400 --warmup 20 > "$O/gclk-$n.txt" 2>&1
  step gclk-$n $?
done
ROUNDS=3 rounds "main gw gclk" --sizes 256,1024 --steps 400 --warmup 20
TEST_TIMEOUT=150 variant_tests gw test_overlap_correct_cpu_cuda test_overlap_correct test_overlap_correct_determinism
echo done t=$SECONDS >> $I; pack
