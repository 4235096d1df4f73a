#!/bin/bash
# Session 27, call 5: test_checkpoint's SIGKILL case (with 4539cf8's report of where files part,
# and its folders kept when they do) eight times at once with HEAD's correction and four times with
# 72dbe32's, plus its SIGTERM case twice with HEAD's; h5diff.py on every kept pair.
#   bash bench/experiments/session27/s27c5.sh BUNDLE.tar.gz      carry: the bundle, v27pre
source tools/gpu/call_lib.sh c5 "$1"
tar -xzf gpu-carry/v27pre.tgz -C /tmp
declare -A D=([head]=$B [pre]=$(shadow pre /tmp/v27pre))
export FLIPFLOW_TEST_DATA=$B/tests/data FLIPFLOW_TEST_DEVICE=cuda
one() {  # V K CASE
  local d=/tmp/w-$1-$2
  mkdir -p $d && (cd $d && timeout 240 ${D[$1]}/bin/test_checkpoint "$3" > $O/t-$1-$2.txt 2>&1
    echo "rc=$? t=$SECONDS" >> $O/t-$1-$2.txt)
}
for k in 1 2 3 4 5 6 7 8; do one head $k "checkpoint: SIGKILL*" & done
for k in 1 2 3 4; do one pre $k "checkpoint: SIGKILL*" & done
for k in 9 10; do one head $k "checkpoint: SIGTERM*" & done
wait
step tests 0
for f in $O/t-*.txt; do echo "$(basename $f): $(grep -E "^(All tests|test cases)" $f | tr '\n' ' ') $(tail -1 $f)"; done >> $I
for ref in /tmp/ff_ckpt_*_ref_*; do
  out=${ref/_ref_/_}
  [[ -d $out ]] || continue
  for h in $ref/*.h5; do python3 bench/experiments/session27/h5diff.py $h $out/$(basename $h) "$(basename $ref)" >> $O/diff.txt 2>&1; done
  ls -la $out >> $O/kept.txt
done
echo done t=$SECONDS >> $I; pack
