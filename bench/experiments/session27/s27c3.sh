#!/bin/bash
# Session 27, call 3: test_checkpoint's SIGKILL case failed in call 2 (HEAD f65b106): the resumed
# run's particles/all/image differed from the uninterrupted one (Catch then spent minutes printing
# the two byte vectors, which read as a hang). Which correction does it, and where the files part:
# for HEAD's correction, 8ad095d's (fused25, before the tail's barrier cut) and 72dbe32's (before
# fused25), ABP N = 400 as the test (checkpoint every 10, keep 2), 6 000 steps: two uninterrupted
# runs, runs stopped at 1 000 and 3 000 steps then resumed, and one killed (SIGKILL at 5 s) then
# resumed; h5diff.py against the first uninterrupted run.
#   bash bench/experiments/session27/s27c3.sh BUNDLE.tar.gz      carry: the bundle, v26fused, v27pre
source tools/gpu/call_lib.sh c3 "$1"
for v in v26fused v27pre; do tar -xzf gpu-carry/$v.tgz -C /tmp; done
declare -A D=([head]=$B [fused]=$(shadow fused /tmp/v26fused) [pre]=$(shadow pre /tmp/v27pre))
A="--set system.N=400 --set step.observe.msd.every=10 --set step.observe.h5md.every=10 --set step.observe.progress.every=1000"
r() {  # V NAME STEPS [EXTRA...]: one run into /tmp/V-NAME
  local v=$1 d=/tmp/$1-$2 steps=$3
  shift 3
  "$@" ${D[$v]}/bin/pipeline run ${D[$v]}/pipelines/abp.yaml $A --set 'run.checkpoint={every: 10, keep: 2}' \
    --set run.steps=$steps --out $d --device cuda --threads 2 $EXTRA >> $d.log 2>&1
  echo "$v $2 $steps rc=$? t=$SECONDS $(tail -c 200 $d.log | tr '\n' ' ')" >> $O/runs.txt
}
for v in head fused pre; do
  rm -rf /tmp/$v-*
  EXTRA= r $v ref1 6000 & EXTRA= r $v ref2 6000 & EXTRA= r $v s1000 1000 & EXTRA= r $v s3000 3000 &
  EXTRA= r $v kill 6000 timeout -s KILL 5 &
  wait
  EXTRA=--resume r $v s1000 6000 & EXTRA=--resume r $v s3000 6000 & EXTRA=--resume r $v kill 6000 &
  wait
  for x in ref2 s1000 s3000 kill; do
    python3 bench/experiments/session27/h5diff.py /tmp/$v-ref1/abp.h5 /tmp/$v-$x/abp.h5 "$v ref1 vs $x" >> $O/diff.txt 2>&1
  done
  step $v 0
done
echo done t=$SECONDS >> $I; pack
