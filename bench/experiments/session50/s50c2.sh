#!/bin/bash
# Session 50, call 2: where the one-block gather kernel (branch gather50clk = gather50 + clock64
# spans by iteration) spends a launch at 256 / 1 024 particles (FF_GCLK prints the table at exit).
#   bash bench/experiments/session50/s50c2.sh gpu-carry/b49f.tar.xz   carry: gpu-carry/b49f.tar.xz, gpu-carry/vgclk.tar.xz
source tools/gpu/call_lib.sh s50c2 "$1"
declare -A D=([main]=$B)
D[gclk]=$(variant gclk gpu-carry/vgclk.tar.xz)
for n in 1024 256; do
  FF_GCLK=1 timeout 100 "${D[gclk]}/bin/pipeline" bench "${D[gclk]}/pipelines/bench-abp.yaml" --device cuda --sizes $n \
    --steps 400 --warmup 20 > "$O/gclk-$n.txt" 2>&1
  step gclk-$n $?
done
echo done t=$SECONDS >> $I; pack
