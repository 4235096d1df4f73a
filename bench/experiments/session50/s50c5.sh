#!/bin/bash
# Session 50, call 5: ncu of the one-block correction at 1 024 particles (bench-abp, three launches
# from the 120th), per-instruction stall sampling: main's edge pass (dense_kernel) and branch
# gather50's kernel by particles (gather_block_kernel), to place the late iterations' ~4 400 cycles.
#   bash bench/experiments/session50/s50c5.sh gpu-carry/b49f.tar.xz   carry: gpu-carry/b49f.tar.xz, gpu-carry/vgather.tar.xz
source tools/gpu/call_lib.sh s50c5 "$1"
declare -A D=([main]=$B)
D[gather]=$(variant gather gpu-carry/vgather.tar.xz)
ncu=$(command -v ncu || ls /usr/local/cuda*/bin/ncu /opt/nvidia/nsight-compute/*/ncu 2>/dev/null | head -n 1)
echo "ncu: ${ncu:-none}" >> "$I"
for v in main gather; do
  k=dense_kernel; [[ $v == gather ]] && k=gather_block_kernel
  timeout 200 "$ncu" --target-processes all --clock-control none -k regex:"$k" --launch-skip 120 --launch-count 3 \
    --section LaunchStats --section SchedulerStats --section WarpStateStats --section InstructionStats \
    --section SourceCounters -f -o "$O/oc-$v" "${D[$v]}/bin/pipeline" bench "${D[$v]}/pipelines/bench-abp.yaml" \
    --device cuda --sizes 1024 --steps 1 --warmup 130 > "$O/ncu-run-$v.txt" 2>&1
  step "ncu-$v" $?
  [[ -f $O/oc-$v.ncu-rep ]] || continue
  "$ncu" -i "$O/oc-$v.ncu-rep" --page details > "$O/ncu-details-$v.txt" 2>&1
  "$ncu" -i "$O/oc-$v.ncu-rep" --page source --csv --print-source sass 2>&1 | xz > "$O/ncu-sass-$v.csv.xz"
  rm -f "$O/oc-$v.ncu-rep"
  step "ncu-export-$v" 0
done
echo done t=$SECONDS >> $I; pack
