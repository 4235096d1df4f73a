#!/bin/bash
# Session 27, call 6: the whole CUDA suite on 4539cf8 (whose test support reports where H5MD files
# part instead of printing them), with three more whole test_checkpoint runs beside it (it failed
# when run whole in calls 1 and 2, never when its SIGKILL case ran alone in call 5); h5diff.py on
# every folder pair a failing case kept.
#   bash bench/experiments/session27/s27c6.sh BUNDLE.tar.gz      carry: the bundle
source tools/gpu/call_lib.sh c6 "$1"
export FLIPFLOW_TEST_DATA=$B/tests/data
for k in 1 2 3; do
  (mkdir -p /tmp/ck$k && cd /tmp/ck$k && FLIPFLOW_TEST_DEVICE=cuda timeout 280 $B/bin/test_checkpoint -d yes > $O/ckpt-$k.txt 2>&1
   echo "rc=$? t=$SECONDS" >> $O/ckpt-$k.txt) &
done
suite $B
wait
step suite 0
for k in 1 2 3; do echo "ckpt-$k: $(grep -E "^(All tests|test cases)" $O/ckpt-$k.txt | tr '\n' ' ') $(tail -1 $O/ckpt-$k.txt)"; done >> $I
for ref in /tmp/ff_ckpt_*_ref_*; do
  out=${ref/_ref_/_}
  [[ -d $out ]] || continue
  for h in $ref/*.h5; do python3 bench/experiments/session27/h5diff.py $h $out/$(basename $h) "$(basename $ref)" >> $O/diff.txt 2>&1; done
  ls -la $ref $out >> $O/kept.txt
done
echo done t=$SECONDS >> $I; pack
