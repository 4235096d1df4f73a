#!/bin/bash
# Session 29, call 5 (the last): the HOOMD-blue row on main's code (bundle b29fin of 6065ec1; main
# after it changed only comments and docs), HOOMD-blue built beside; meanwhile where a tail gather's
# cycles go after pm29/fin29 (overlap-tail-gather-clocks.patch, session 29's version: take needs
# the gathered position) at 2^10 and 2^14.
#   v29tclk2: git apply bench/experiments/session29/overlap-tail-gather-clocks.patch; cmake --build
#     build-var --target flipflow_stage_overlap_correct; its plugin to /tmp/v29tclk2 (patchelf
#     --set-rpath '$ORIGIN/../../lib'); tar -czf gpu-carry/v29tclk2.tgz -C /tmp v29tclk2
#   bash bench/experiments/session29/s29c5.sh gpu-carry/b29fin.tar.gz   carry: b29fin, v29tclk2, hoomd-kit.tgz
source tools/gpu/call_lib.sh c5 "$1"
tar -xzf gpu-carry/hoomd-kit.tgz
(OUT=$O HOOMD_JOBS=16 nice -n 19 bash hoomd-kit/build.sh 420 > $O/hoomd-build.txt 2>&1; echo "build rc=$? t=$SECONDS" >> $O/hoomd-build.txt) &
build=$!
tar -xzf gpu-carry/v29tclk2.tgz -C /tmp
declare -A D=([fin]=$B [tclk]=$(shadow tclk /tmp/v29tclk2))
for n in 1024 16384; do
  timeout 120 ${D[tclk]}/bin/pipeline bench ${D[tclk]}/pipelines/bench-abp.yaml --device cuda --sizes $n --steps 200 \
    --warmup 20 2>&1 | grep TCLK > $O/tclk-$n.txt
  step tclk-$n 0
done
wait $build; step hoomd-build 0
((SECONDS < 470)) && { OUT=$O timeout $((500 - SECONDS)) bash hoomd-kit/run.sh --sizes 16384 1048576 --dts 2e-3 --max-seconds 8 > $O/hoomd-run.txt 2>&1; step hoomd $?; }
((SECONDS < 500)) && BENCH_TIMEOUT=$((530 - SECONDS)) bench_abp fin hoomd-row --sizes 16384,1048576 --steps 200 --warmup 20
echo done t=$SECONDS >> $I; pack
