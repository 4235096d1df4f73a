#!/bin/bash
# Session 40, call 1 (nvidia-h200): the whole CUDA suite on the session's code (test_h5md split in
# three, simulation_team.cpp, observe.clusters' exact sizes and sizes_layout: long), bench-abp's
# rows, then ncu of abp.integrate's and detect's marking kernels at 2^20 (never profiled: session
# 18's notes left them at ~2-3x their memory traffic's time without a reason).
#   bash bench/experiments/session40/s40c1.sh gpu-carry/BUNDLE.tar.gz [NAME]   carry: the bundle
source tools/gpu/call_lib.sh "${2:-s40c1}" "$1"
suite "$B" 200
step suite 0
declare -A D=([main]=$B)
bench_abp main rows --sizes 1024,16384,1048576 --steps 200 --warmup 20
ncu=$(command -v ncu || ls /usr/local/cuda*/bin/ncu /opt/nvidia/nsight-compute/*/ncu 2>/dev/null | head -n 1)
echo "ncu: ${ncu:-none}" >> "$I"
timeout 150 "$ncu" --target-processes all --clock-control none --kernel-name-base demangled \
  -k regex:"overdamped_kernel|OverdampedStep|mark_kernel" --launch-skip 40 --launch-count 4 \
  --section LaunchStats --section Occupancy --section SpeedOfLight --section MemoryWorkloadAnalysis \
  --section WarpStateStats --section ComputeWorkloadAnalysis \
  "$B/bin/pipeline" bench "$B/pipelines/bench-abp.yaml" --device cuda --sizes 1048576 --steps 5 --warmup 30 \
  > "$O/ncu-integrate-detect.txt" 2>&1
step ncu $?
echo done t=$SECONDS >> $I; pack
