#!/bin/bash
# Session 33, call 4: the StreamMark fix (6680e9b). test_observe_h5md's new CUDA case on the
# fixed bundle and on a test executable built with the header before the fix (v33old: build-var,
# core/backend/host_buffer.h of 4f73933, rpath $ORIGIN/../lib); test_checkpoint three times at
# once, as the suite found it (call 3).
#   bash bench/experiments/session33/s33c4.sh gpu-carry/b33c.tar.gz   carry: b33c, v33old
source tools/gpu/call_lib.sh c4 "$1"
tar -xzf gpu-carry/v33old.tgz -C /tmp
cp /tmp/v33old/test_observe_h5md_old "$B/bin/"
(cd /tmp && FLIPFLOW_TEST_DEVICE=cuda timeout 60 "$B/bin/test_observe_h5md_old" "[cuda]" > $O/old.txt 2>&1; echo "rc=$?" >> $O/old.txt)
echo "old: $(tail -1 $O/old.txt)" >> $I
rm "$B/bin/test_observe_h5md_old"
for k in a b c; do
  TEST_TIMEOUT=200 tests $B $O/tests-$k.txt test_checkpoint $([[ $k == a ]] && echo test_observe_h5md) &
done
wait
echo "tests: $(cat $O/tests-[abc].txt | grep -c ^PASS) PASS, $(cat $O/tests-[abc].txt | grep -c ^FAIL) FAIL; $(grep -h ^rc= $O/tests-[abc].txt | tr '\n' ' ')" >> $I
(cd /tmp && FLIPFLOW_TEST_DEVICE=cuda "$B/bin/test_observe_h5md" "[cuda]" > $O/new.txt 2>&1; echo "rc=$?" >> $O/new.txt)
echo done t=$SECONDS >> $I; pack
