#!/bin/bash
# Session 24, call 4 (one H200): the whole CUDA suite on main with loop.cuh's launch shape in one
# place (bundle b24b), in four groups at once (the device time left: ~350 s).
#   carry: gpu-carry/b24b.tar.gz
source tools/gpu/call_lib.sh c4 "$1"
# test_out_of_memory runs alone after them: it fills the GPU's memory on purpose.
all=$(cd $B/bin && ls test_* | grep -v '^test_out_of_memory$' | awk '{print NR % 4, $0}')
for g in 0 1 2 3; do
  TEST_TIMEOUT=200 tests $B $O/tests-$g.txt $(echo "$all" | awk -v g=$g '$1 == g {print $2}') &
done
wait
TEST_TIMEOUT=40 tests $B $O/tests-oom.txt test_out_of_memory
{ echo "tests: $(cat $O/tests-*.txt | grep -c "^PASS") PASS, $(cat $O/tests-*.txt | grep -c "^FAIL") FAIL"; cat $O/tests-*.txt | grep "^FAIL"; grep -h "^rc=" $O/tests-*.txt; } >> $I
echo done t=$SECONDS >> $I; pack
