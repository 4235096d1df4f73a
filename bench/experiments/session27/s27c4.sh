#!/bin/bash
# Session 27, call 4: call 3 found no difference in 6 000-step runs (uninterrupted twice, resumed
# from 1 000 and 3 000, killed and resumed; HEAD's, 8ad095d's and 72dbe32's corrections), while
# test_checkpoint's 20 000-step SIGKILL case failed. Longer runs: ABP N = 400 as the test, 30 000
# steps, four with HEAD's correction (three uninterrupted, one stopped at 3 000 and resumed) and
# three with 72dbe32's, all at once; h5diff.py against each one's first run.
#   bash bench/experiments/session27/s27c4.sh BUNDLE.tar.gz      carry: the bundle, v27pre
source tools/gpu/call_lib.sh c4 "$1"
tar -xzf gpu-carry/v27pre.tgz -C /tmp
declare -A D=([head]=$B [pre]=$(shadow pre /tmp/v27pre))
A="--set system.N=400 --set step.observe.msd.every=10 --set step.observe.h5md.every=10 --set step.observe.progress.every=1000"
r() {  # V NAME STEPS [--resume]: one run into /tmp/V-NAME
  local v=$1 name=$2 steps=$3 d=/tmp/$1-$2
  shift 3
  ${D[$v]}/bin/pipeline run ${D[$v]}/pipelines/abp.yaml $A --set 'run.checkpoint={every: 10, keep: 2}' \
    --set run.steps=$steps --out $d --device cuda --threads 2 "$@" >> $d.log 2>&1
  echo "$v $name $steps $* rc=$? t=$SECONDS $(tail -c 160 $d.log | tr '\n' ' ')" >> $O/runs.txt
}
rm -rf /tmp/head-* /tmp/pre-*
(r head s3000 3000; r head s3000 30000 --resume) &
for x in ref1 ref2 ref3; do r head $x 30000 & r pre $x 30000 & done
wait
step runs 0
for x in ref2 ref3 s3000; do python3 bench/experiments/session27/h5diff.py /tmp/head-ref1/abp.h5 /tmp/head-$x/abp.h5 "head ref1 vs $x" >> $O/diff.txt 2>&1; done
for x in ref2 ref3; do python3 bench/experiments/session27/h5diff.py /tmp/pre-ref1/abp.h5 /tmp/pre-$x/abp.h5 "pre ref1 vs $x" >> $O/diff.txt 2>&1; done
python3 bench/experiments/session27/h5diff.py /tmp/pre-ref1/abp.h5 /tmp/head-ref1/abp.h5 "pre ref1 vs head ref1" >> $O/diff.txt 2>&1
echo done t=$SECONDS >> $I; pack
