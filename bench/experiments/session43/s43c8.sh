#!/bin/bash
# Session 43, call 8: issue 20's rows on main 38e13f2 (flipstore43 merged), as session 42's call 4:
# HOOMD-blue is built on the host's cores while the whole CUDA suite runs; then HOOMD-blue's ABP +
# WCA row, flipflow's at 2^10, 2^14 and 2^20 right after, 2^20 after 3 000 steps, Carter side by
# side and the sweep row.
#   bash bench/experiments/session43/s43c8.sh gpu-carry/b43b.tar.xz   carry: gpu-carry (the bundle,
#   hoomd-kit.tgz = ../shared/peers-gpu/hoomd as hoomd-kit/, peers-bundle.tar.gz = ../shared/peers-gpu/bundle)
source tools/gpu/call_lib.sh "${2:-s43c8}" "$1"
declare -A D=([main]=$B)
tar -xzf gpu-carry/hoomd-kit.tgz
(OUT=$O HOOMD_JOBS=16 nice -n 19 bash hoomd-kit/build.sh 420 > $O/hoomd-build.txt 2>&1; echo "build rc=$? t=$SECONDS" >> $O/hoomd-build.txt) &
build=$!
suite "$B" 280
step suite 0
wait $build; step hoomd-build 0
((SECONDS < 440)) && { OUT=$O timeout $((470 - SECONDS)) bash hoomd-kit/run.sh --sizes 16384 1048576 --dts 2e-3 --max-seconds 8 > $O/hoomd-run.txt 2>&1; step hoomd $?; }
bench_abp main hoomd-row --sizes 1024,16384,1048576 --steps 200 --warmup 20
bench_abp main late --sizes 1048576 --steps 100 --warmup 3000
mkdir -p /tmp/pb && tar -xzf gpu-carry/peers-bundle.tar.gz -C /tmp/pb
((SECONDS < 500)) && { timeout $((560 - SECONDS)) bash bench/carter_side_by_side.sh $B /tmp/pb/bundle $O/carter small > $O/carter-run.txt 2>&1; step carter $?; }
((SECONDS < 540)) && sweep_abp 1
echo done t=$SECONDS >> $I; pack
