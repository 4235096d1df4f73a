#!/bin/bash
# Session 50, call 7: the HOOMD-blue row's Δt question on today's code. HOOMD-blue (ABP + WCA,
# Δt 2e-3) at 2^14 and 2^20, then bench-abp (main's code, b49f) at Δt 0.01 and 0.02, three
# interleaved rounds of 200 steps after 20: simulated time per wall second of each.
#   bash bench/experiments/session50/s50c7.sh gpu-carry/b49f.tar.xz   carry: gpu-carry/b49f.tar.xz, gpu-carry/hoomd-kit.tgz
source tools/gpu/call_lib.sh s50c7 "$1"
declare -A D=([main]=$B)
tar -xzf gpu-carry/hoomd-kit.tgz
OUT=$O HOOMD_JOBS=16 bash hoomd-kit/build.sh 420 > "$O/hoomd-build.txt" 2>&1
step hoomd-build $?
OUT=$O timeout 120 bash hoomd-kit/run.sh --sizes 16384 1048576 --dts 2e-3 --max-seconds 8 > "$O/hoomd-run.txt" 2>&1
step hoomd $?
for r in 1 2 3; do
  for dt in 0.01 0.02; do bench_abp main dt$dt-r$r --sizes 16384,1048576 --steps 200 --warmup 20 --set run.dt=$dt; done
done
echo done t=$SECONDS >> $I; pack
