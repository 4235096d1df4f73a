#!/bin/bash
# Session 48, call 3: what the integrator's draws cost at small N (branch noiseprobe48, timing
# only: with FF_NOISE_PROBE the integrator reads its Gaussians from a table filled once, so every
# step draws the same noise; the physics is not the shipped one). CUPTI timelines of bench-abp
# 1 024 and bench-hd07 16 384 with and without the probe (the kernels' own durations), then
# bench-abp 1 024 / 16 384 and bench-hd07 16 384, three interleaved rounds.
#   bash bench/experiments/session48/s48c3.sh gpu-carry/b48.tar.xz   carry: gpu-carry (b48, vprobe)
source tools/gpu/call_lib.sh s48c3 "$1"
declare -A D=([main]=$B)
D[probe]=$(variant probe gpu-carry/vprobe.tar.xz)
B0=$B
B=${D[probe]}
for mode in draw table; do
  if [[ $mode == table ]]; then export FF_NOISE_PROBE=1; else unset FF_NOISE_PROBE; fi
  timelines 1024
  TRACE_PIPELINE=bench-hd07 TRACE_MARKER=overdamped timelines 16384
  for f in "$O"/trace-1024* "$O"/trace-bench-hd07-16384*; do [[ -e $f ]] && mv "$f" "$(dirname "$f")/$mode-$(basename "$f")"; done
done
unset FF_NOISE_PROBE
B=$B0
for r in 1 2 3; do
  for mode in draw table; do
    if [[ $mode == table ]]; then export FF_NOISE_PROBE=1; else unset FF_NOISE_PROBE; fi
    bench_abp probe "$mode-r$r" --sizes 1024,16384 --steps 400 --warmup 20
    timeout 120 "${D[probe]}/bin/pipeline" bench "${D[probe]}/pipelines/bench-hd07.yaml" --device cuda --sizes 16384 \
      --steps 400 --warmup 20 2>&1 | grep -E "^[0-9]|overlap_correct/iter|rror" | sed "s/^/$mode r$r: /" >> "$O/hd07.txt"
    step "hd07-$mode-r$r" 0
  done
done
unset FF_NOISE_PROBE
echo done t=$SECONDS >> $I; pack
