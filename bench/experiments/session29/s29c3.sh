#!/bin/bash
# Session 29, call 3: branch pm29 (a pair's push as (δ/r)·r_k, its depth against tol·σ, the fixed
# point's unit once per rule; other bits than main's) as a whole bundle: every CUDA test, then
# bench-abp against main's overlap_correct plugin in the same bundle, three rounds at
# 2^10..2^16, once at 2^20 and after 3 000 steps at 2^20, and the 64-run sweep row.
#   rm -rf bundle && tools/bundle build bundle (on pm29) && tar -cf - bundle | gzip -5 > gpu-carry/b29pm.tar.gz
#   v29head: main's plugin from gpu-carry/b29.tar.gz (bundle/plugins/libflipflow_stage_overlap_correct.so)
#   bash bench/experiments/session29/s29c3.sh gpu-carry/b29pm.tar.gz   carry: the bundle, v29head
source tools/gpu/call_lib.sh c3 "$1"
tar -xzf gpu-carry/v29head.tgz -C /tmp
declare -A D=([pm]=$B [head]=$(shadow head /tmp/v29head))
suite $B
step suite 0
for v in head pm pm head head pm; do bench_abp $v ab --sizes 1024,4096,16384,65536 --steps 200 --warmup 20; done
for v in head pm; do bench_abp $v big --sizes 1048576 --steps 200 --warmup 20; done
for v in pm head; do bench_abp $v late --sizes 1048576 --steps 100 --warmup 3000; done
sweep_abp 1
echo done t=$SECONDS >> $I; pack
