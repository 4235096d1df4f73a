#!/bin/bash
# Session 41, call 11 (nvidia-h200): the dense block's reach test in float where the offset is
# its own minimum image (branch dense41b), against the merged dense block (main 0f79a41's plugin)
# and main 1a62138's (the cluster team): bench-abp at 2^10 and 1 536, three interleaved rounds;
# then the correction's CUDA tests and the error cases on the variant.
#   bash bench/experiments/session41/s41c11.sh gpu-carry/BUNDLE.tar.gz gpu-carry/MERGED.tar.gz gpu-carry/OLD.tar.gz   carry: gpu-carry
source tools/gpu/call_lib.sh "${4:-s41c11}" "$1"
mkdir -p /tmp/mp && tar -xzf "$2" -C /tmp/mp
MERGED=$(shadow merged /tmp/mp)
declare -A D=([main]=$B [merged]=$MERGED)
vs="main merged"
if [[ -f ${3:-} ]]; then  # (the old plugin too, where the carry has room for it)
  mkdir -p /tmp/oldp && tar -xzf "$3" -C /tmp/oldp
  D[old]=$(shadow old /tmp/oldp)
  vs="$vs old"
fi
for r in 1 2 3; do
  for v in $vs; do bench_abp $v r$r --sizes 1024,1536 --steps 200 --warmup 20; done
done
[[ ${SKIP_TESTS:-0} == 1 ]] || { TEST_TIMEOUT=240 correction_tests main; tests "$B" "$O/errors.txt" test_overlap_correct_errors; step errors 0; }
echo done t=$SECONDS >> $I; pack
