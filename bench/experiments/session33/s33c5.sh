#!/bin/bash
# Session 33, call 5: 5c42b9f's two fixes for branched CUDA steps (a stage skipped by every
# records its join event; an upload lands before another stream reads the field). Their new CUDA
# cases (test_scheduler, test_backend) on the bundle and on a copy of it whose libflipflow.so is
# built without the fixes (v33pre: build-var, scheduler.cpp and device_buffer.cpp of 5c42b9f's
# parent), then the whole CUDA suite on the bundle (the session's last code).
#   bash bench/experiments/session33/s33c5.sh gpu-carry/b33d.tar.gz   carry: b33d, v33pre
source tools/gpu/call_lib.sh c5 "$1"
tar -xzf gpu-carry/v33pre.tgz -C /tmp
P=/tmp/pre; rm -rf $P; cp -a $B $P; cp /tmp/v33pre/libflipflow.so $P/lib/libflipflow.so
for v in new pre; do
  d=$B; [[ $v == pre ]] && d=$P
  for t in test_scheduler test_backend; do
    (cd /tmp && FLIPFLOW_TEST_DEVICE=cuda timeout 60 $d/bin/$t "[cuda]" > $O/$v-$t.txt 2>&1; echo "rc=$?" >> $O/$v-$t.txt)
    echo "$v $t: $(grep -E '^(All tests|test cases)' $O/$v-$t.txt | tr '\n' ' ') $(tail -1 $O/$v-$t.txt)" >> $I
  done
done
step fixes 0
suite "$B" 280
step suite 0
echo done t=$SECONDS >> $I; pack
