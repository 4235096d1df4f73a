#!/usr/bin/env bash
# Several GPUs, decomposed teams (issue 21 items 2-3): the 2- and 4-GPU bit tests of the
# decomposed Verlet and Delaunay pipelines, then weak scaling (2^20 particles a GPU) of the
# decomposed LJ and hard-sphere pipelines on 1, 2, 4 and 8 GPUs, as many as `nvidia-smi -L` lists.
# Its parts ran on two H200s in session 20 (bench/README.md, "Session 20"); never yet on 4.
#
#   bench/multi_gpu_decomposed.sh BUNDLE OUT
#
# BUNDLE: a tools/bundle of a CUDA build; NCCL is the machine's own (as bench/multi_gpu_phoretic.sh).
# OUT gets info.txt, tests.txt and bench-<pipeline>-<gpus>.txt.
set -uo pipefail
(($# == 2)) || { echo "usage: $0 BUNDLE OUT" >&2; exit 2; }
B=$(cd "$1" && pwd) || exit 2
mkdir -p "$2" && OUT=$(cd "$2" && pwd) || exit 2
SECONDS=0
export NCCL_NVLS_ENABLE=0 NCCL_DEBUG=WARN  # never NVLink multicast
for d in /usr/local/cuda/lib64 /usr/lib/x86_64-linux-gnu \
  $(python3 -c 'import nvidia.nccl, os; print(os.path.dirname(nvidia.nccl.__file__) + "/lib")' 2>/dev/null); do
  [[ -z ${FLIPFLOW_NCCL_LIBRARY:-} && -f $d/libnccl.so.2 ]] && export FLIPFLOW_NCCL_LIBRARY=$d/libnccl.so.2
done
{ nvidia-smi -L; echo "nccl=${FLIPFLOW_NCCL_LIBRARY:-through the loader}"; } > "$OUT/info.txt"
G=$(nvidia-smi -L | grep -c '^GPU ')
(cd "$B" && FLIPFLOW_TEST_DEVICE=cuda timeout 240 bin/run-tests test_decomposition test_decomposition_delaunay test_team \
  > "$OUT/tests.txt" 2>&1; echo "rc=$? t=$SECONDS" >> "$OUT/tests.txt")
for y in decomp-lj decomp-hard-spheres; do
  for g in 1 2 4 8; do
    ((g <= G)) || continue
    timeout 120 "$B/bin/pipeline" bench "$B/tests/data/$y.yaml" --gpus $g --sizes $((1048576 * g)) \
      --steps 100 --warmup 20 > "$OUT/bench-$y-$g.txt" 2>&1
    echo "$y gpus=$g rc=$? t=$SECONDS" >> "$OUT/info.txt"
    ((SECONDS > 520)) && break 2
  done
done
