#!/bin/bash
# Session 35, call 2 (one H200): does bench-abp's 200-steps-after-20 protocol measure small N
# below the GPU's full clock? The GPU idles while each size is set up on the host (plugins,
# initial state, CGAL's triangulation), and 20 warm-up steps at 2^10 are ~1.4 ms of work.
# Interleaved, three rounds at 2^10, 2^12, 2^14: bench-abp alone, and with gpu_spin.cu keeping
# one SM busy beside it (the clock held up); nvidia-smi samples the SM clock every 20 ms.
#   bash bench/experiments/session35/s35c2.sh gpu-carry/BUNDLE.tar.gz   carry: the bundle
source tools/gpu/call_lib.sh s35c2 "$1"
declare -A D=([main]=$B)
nvcc -O2 -arch=sm_90 -o /tmp/gpu_spin bench/experiments/session35/gpu_spin.cu > $O/spin-build.txt 2>&1
step spin-build $?
nvidia-smi --query-gpu=timestamp,clocks.sm,utilization.gpu --format=csv,noheader -lms 20 > $O/clocks.txt 2>&1 &
smi=$!
for r in 1 2 3; do
  echo "round $r alone t=$SECONDS" >> $O/ab.txt
  bench_abp main alone$r --sizes 1024,4096,16384
  /tmp/gpu_spin 40 > $O/spin$r.txt 2>&1 &
  spin=$!
  sleep 1
  echo "round $r spin t=$SECONDS" >> $O/ab.txt
  bench_abp main spin$r --sizes 1024,4096,16384
  kill $spin 2>/dev/null; wait $spin 2>/dev/null
  sleep 2
done
echo "long t=$SECONDS" >> $O/ab.txt
bench_abp main long --sizes 1024,16384 --steps 2000 --warmup 2000
kill $smi
echo done t=$SECONDS >> $I; pack
