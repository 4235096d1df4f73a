#!/bin/bash
# Session 27, call 2: test_checkpoint printed nothing within 280 s in session 26's call 5 (e78df67's
# correction) and in this session's call 1 (HEAD f65b106); it passed in 32 s with 72dbe32's and with
# loc's (session 26 calls 1 and 4). Where it stops, and which correction does:
#   1. test_checkpoint alone (HEAD), each test case's duration as it ends (-d yes), a watchdog
#      listing the pipeline processes still running every 20 s;
#   2. ABP N = 400 runs as the test's (checkpoint every 10), 30 000 steps, two each with HEAD's
#      correction, loc's and 8ad095d's (fused25, before the tail's barrier cut), 150 s limit;
#   3. compute-sanitizer racecheck, synccheck and memcheck on 200 steps of that run (HEAD).
#   bash bench/experiments/session27/s27c2.sh BUNDLE.tar.gz      carry: the bundle, v26loc, v26fused
source tools/gpu/call_lib.sh c2 "$1"
for v in v26loc v26fused; do tar -xzf gpu-carry/$v.tgz -C /tmp; done
declare -A D=([head]=$B [loc]=$(shadow loc /tmp/v26loc) [fused]=$(shadow fused /tmp/v26fused))
export FLIPFLOW_TEST_DATA=$B/tests/data
mkdir -p /tmp/ck && (cd /tmp/ck && FLIPFLOW_TEST_DEVICE=cuda timeout 270 $B/bin/test_checkpoint -d yes > $O/ckpt.txt 2>&1
  echo "rc=$? t=$SECONDS" >> $O/ckpt.txt) &
ck=$!
(for i in $(seq 1 13); do sleep 20; { echo "== t=$SECONDS"; ps -eo pid,etimes,pcpu,args | grep "[b]in/pipeline" | cut -c1-600
  nvidia-smi --query-gpu=utilization.gpu,memory.used --format=csv,noheader; } >> $O/watch.txt; done) &
A="--set system.N=400 --set step.observe.msd.every=10 --set step.observe.h5md.every=10 --set step.observe.progress.every=1000"
run400() {  # V K
  local d=/tmp/r-$1-$2 t=$SECONDS
  rm -rf $d; mkdir -p $d
  timeout 150 ${D[$1]}/bin/pipeline run ${D[$1]}/pipelines/abp.yaml $A --set 'run.checkpoint={every: 10, keep: 2}' \
    --set run.steps=30000 --set run.seed=$((100 + $2)) --out $d --device cuda --threads 2 > $d/log 2>&1
  local rc=$?
  echo "$1 $2 rc=$rc s=$((SECONDS - t)) | $(tail -c 300 $d/log | tr '\n' ' ')" >> $O/stress.txt
}
pids=()
for v in head loc fused; do for k in 1 2; do run400 $v $k & pids+=($!); done; done
wait "${pids[@]}"
step stress 0
S=/usr/local/cuda/bin/compute-sanitizer
for tool in racecheck synccheck memcheck; do
  rm -rf /tmp/san; mkdir -p /tmp/san
  timeout 120 $S --tool $tool --print-limit 20 $B/bin/pipeline run $B/pipelines/abp.yaml $A --set run.steps=200 \
    --out /tmp/san --device cuda --threads 2 > $O/san-$tool.txt 2>&1
  step "san-$tool" $?
done
wait $ck
cp /tmp/ff_ckpt_*.log $O/ 2>/dev/null
step ckpt 0
echo done t=$SECONDS >> $I; pack
