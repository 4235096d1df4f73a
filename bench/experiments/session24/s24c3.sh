#!/bin/bash
# Session 24, call 3 (one H200): HOOMD-blue built with all 16 cores (call 2's build, on 12 cores
# beside the benchmarks, did not finish in 420 s); meanwhile phoretic c0–c4 short at 2^20 (GPU-
# bound steps); then HOOMD's ABP + WCA and bench-abp at 2^14 and 2^20 (main, b24a), one lease.
#   carry: gpu-carry/b24a.tar.gz gpu-carry/hoomd-kit.tgz
source tools/gpu/call_lib.sh c3 "$1"
tar -xzf gpu-carry/hoomd-kit.tgz
(OUT=$O bash hoomd-kit/build.sh 400 > $O/hoomd-build.txt 2>&1; echo "build rc=$? t=$SECONDS" >> $O/hoomd-build.txt) &
build=$!
P=$B/pipelines
b() { local tag=$1 file=$2; shift 2
  timeout 90 $B/bin/pipeline bench $P/$file.yaml --device cuda "$@" 2>&1 |
    grep -E "^[0-9]|overlap_correct/iter|rror" | sed "s/^/$tag: /" >> $O/ab.txt; step $tag $?; }
for c in 0 1 2 3 4; do b phoretic-c$c phoretic-c$c-short --sizes 1048576 --steps 50 --warmup 20; done
wait $build; step hoomd-build 0
((SECONDS < 480)) && { OUT=$O timeout $((560 - SECONDS)) bash hoomd-kit/run.sh --sizes 16384 1048576 --dts 2e-3 --max-seconds 8 > $O/hoomd-run.txt 2>&1; step hoomd $?; }
((SECONDS < 560)) && b hoomd-row bench-abp --sizes 16384,1048576 --steps 200 --warmup 20
echo done t=$SECONDS >> $I; pack
