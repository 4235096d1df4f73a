#!/bin/bash
# Session 24, call 1 (one H200): programmatic launches for the integrator's loop and for
# overlap_correct's cooperative grid (main, bundle b24a) against the plugins before them (abp
# and overlap_correct of 4a8a34a in a shadow bundle): bench-abp at 2^10 … 2^20, interleaved; the
# 64-run sweep (programmatic launches are off there since 5dcb01a); then the whole CUDA suite.
#   carry: gpu-carry/b24a.tar.gz gpu-carry/v24-before.tgz
source tools/gpu/call_lib.sh c1 "$1"
tar -xzf gpu-carry/v24-before.tgz -C gpu-carry
OLD=$(shadow before gpu-carry/before)
P=$B/pipelines
b() { local tag=$1 dir=$2; shift 2
  timeout 90 $dir/bin/pipeline bench $P/bench-abp.yaml --device cuda "$@" 2>&1 |
    grep -E "^[0-9]|overlap_correct/iter|rror" | sed "s/^/$tag: /" >> $O/ab.txt; step $tag $?; }
for r in new old old new new old; do [[ $r == new ]] && d=$B || d=$OLD
  b $r $d --sizes 1024,4096,16384,65536 --steps 300 --warmup 20; done
for r in new old; do [[ $r == new ]] && d=$B || d=$OLD; b $r-big $d --sizes 1048576 --steps 200 --warmup 20; done
sw() { rm -rf /tmp/sw; timeout 60 $B/bin/pipeline sweep $P/bench-abp.yaml --device cuda --set system.N=16384 --set run.steps=5000 --replicas 64 --out /tmp/sw --concurrent 64 --in-process 2>&1 | tail -2 | sed "s/^/sweep $1: /" >> $O/sweep.txt; step sweep$1 $?; }
sw 1; sw 2
TEST_TIMEOUT=$((590 - SECONDS)) tests $B $O/tests-all.txt
{ echo "tests: $(grep -c "^PASS" $O/tests-all.txt) PASS, $(grep -c "^FAIL" $O/tests-all.txt) FAIL"; grep "^FAIL\|SKIP" $O/tests-all.txt | head -20; tail -3 $O/tests-all.txt; } >> $I
echo done t=$SECONDS >> $I; pack
