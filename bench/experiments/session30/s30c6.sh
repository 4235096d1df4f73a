#!/bin/bash
# Session 30, call 6: the shared-memory tail's gathers and checks of few particles by one thread
# each instead of lane groups (shared-tail-threads.patch on 55b6fa7: gthr the gathers, cthr the
# checks, thr both), against 55b6fa7 (compact), bench-abp 200 steps after 20 at 2^10 / 2^11 / 2^12,
# three interleaved rounds.
#   bash bench/experiments/session30/s30c6.sh gpu-carry/b30d.tar.gz    carry: the bundle, v30gthr/v30cthr/v30thr.tgz
source tools/gpu/call_lib.sh c6 "$1"
for v in v30gthr v30cthr v30thr; do tar -xzf gpu-carry/$v.tgz -C /tmp; done
declare -A D=([compact]=$B [gthr]=$(shadow gthr /tmp/v30gthr) [cthr]=$(shadow cthr /tmp/v30cthr) [thr]=$(shadow thr /tmp/v30thr))
for r in 1 2 3; do
  for v in compact gthr cthr thr; do bench_abp $v small --sizes 1024,2048,4096 --steps 200 --warmup 20; done
done
echo done t=$SECONDS >> $I; pack
