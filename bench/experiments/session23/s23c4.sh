#!/bin/bash
# Session 23, call 4 (one H200): the whole suite on CUDA with the session's final code, in six
# streams ([long] left to the CPU suite), and how often the gate closes in the two pipelines
# test_cpu_cuda_bits compares (abp.yaml, hard-disks.yaml at their N, 1 000 steps): the steps that
# run flip, Lawson and the correction again after the host's decision.
source tools/gpu/call_lib.sh c4 "$1"
P=$B/pipelines
for p in abp hard-disks; do
  timeout 60 $B/bin/pipeline bench $P/$p.yaml --device cuda --steps 1000 --warmup 0 > $O/closed-$p.txt 2>&1; step closed-$p $?
done
all=$(cd $B/bin && ls test_* | sort)
k=0
for t in $all; do echo $t >> $O/stream-$((k % 6)).list; k=$((k + 1)); done
for s in 0 1 2 3 4 5; do TEST_TIMEOUT=240 tests $B $O/suite-$s.txt $(cat $O/stream-$s.list) & done
wait
{ echo "suite: $(cat $O/suite-*.txt | grep -c "^PASS") PASS, $(cat $O/suite-*.txt | grep -c "^FAIL") FAIL, $(cat $O/suite-*.txt | grep -c "^SKIP") SKIP of $k"; grep -h "^FAIL\|^rc=" $O/suite-*.txt; } >> $I
echo done t=$SECONDS >> $I; pack
