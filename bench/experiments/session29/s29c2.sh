#!/bin/bash
# Session 29, call 2: where the tail gather's pair math goes (session 28's clocks: ~1 050 of a
# gather's ~3 750 cycles), and two cuts of it on bench-abp.
#   pair_math_latency.cu (built here: nvcc -O3 -arch=sm_90 -std=c++17 -fmad=false -I.; carried
#     as gpu-carry/pml): one round of the math as a dependent chain, per variant
#   v29near: kernel.h's min_image skips the rounding for |d| <= L/4 on the device too, as the
#     host always did (the same bits)
#   v29div:  pair_term_d's t = (delta/len)*r, one division for both components (other bits)
#   v29nd:   both
#   bash bench/experiments/session29/s29c2.sh gpu-carry/b29.tar.gz   carry: the bundle, v29near, v29div, v29nd, pml
source tools/gpu/call_lib.sh c2 "$1"
for v in v29near v29div v29nd; do tar -xzf gpu-carry/$v.tgz -C /tmp; done
declare -A D=([head]=$B [near]=$(shadow near /tmp/v29near) [div]=$(shadow div /tmp/v29div) [nd]=$(shadow nd /tmp/v29nd))
gpu-carry/pml > $O/pml.txt 2>&1
step pml $?
correction_tests near div nd
for v in head near div nd nd div near head head nd near div; do
  bench_abp $v ab --sizes 1024,4096,16384,65536 --steps 200 --warmup 20
done
bench_abp head big --sizes 1048576 --steps 200 --warmup 20
bench_abp nd big --sizes 1048576 --steps 200 --warmup 20
echo done t=$SECONDS >> $I; pack
