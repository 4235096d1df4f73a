#!/bin/bash
# ptxas's registers / spills / shared memory of voronoi.geometry's CUDA loop, compiled as build/
# compiles it for the stage plugin (sm_90, no fma contraction), from the tree or from a commit.
#   bench/experiments/vor3/ptxas.sh [COMMIT]
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../../.." && pwd)
inc=$root
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
if [[ -n ${1:-} ]]; then
  mkdir -p "$tmp/stages/voronoi/geometry"
  for f in stage.h kernel.h fields.h cuda.cu; do git -C "$root" show "$1:stages/voronoi/geometry/$f" > "$tmp/stages/voronoi/geometry/$f"; done
  inc=$tmp
fi
cd "$root/build/stages/voronoi"
/usr/local/cuda/bin/nvcc -O3 -DNDEBUG -DFLIPFLOW_HAVE_CUDA --generate-code=arch=compute_90,code=sm_90 -Xcompiler=-fPIC \
  -std=c++17 -fmad=false -I"$inc" --options-file CMakeFiles/flipflow_stage_voronoi.dir/includes_CUDA.rsp \
  -Xptxas -v -c "$inc/stages/voronoi/geometry/cuda.cu" -o "$tmp/x.o" 2>&1 | grep -E "Compiling|registers|spill" |
  paste - - - | while IFS=$'\t' read -r a b c; do
    f=$(sed -E "s/.*entry function '([^']*)'.*/\1/" <<< "$a")
    echo "$(c++filt "$f" | sed -E 's/ff::[a-z_0-9]+:://g; s/\(anonymous namespace\):://g' | cut -c1-70) | $(sed -E 's/ptxas info *: //' <<< "$b") | $(sed -E 's/ptxas info *: //' <<< "$c")"
  done
