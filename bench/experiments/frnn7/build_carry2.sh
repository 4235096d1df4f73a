#!/bin/bash
# Second batch (run2.sh, ab2.yaml): builds into $DEST (default /work/main/gpu-carry/frnn7b)
# so.tar.xz with
#   ab/      one plugin with every variant as a stage frnn_ab.<v> and frnn_ab.<v>2 (second round)
#   <v>/     the neighbors stage plugin of each variant in TESTS, for its CUDA tests
# each .so with rpath $ORIGIN/../../lib, and run2.sh and ab2.yaml beside it. Run from the worktree
# root with a clean stages/neighbors/delaunay/ and no plugins/frnn_ab.
#   main = 09b83dc's folder (main's search before this branch); src = ce882c4 (this branch's
#   source: fm4bc); the others: bench/experiments/frnn7/<v>.patch on ce882c4.
set -euo pipefail
dest=${DEST:-/work/main/gpu-carry/frnn7b}
P=bench/experiments/frnn7
OLD=09b83dc
SRC=ce882c4
VARIANTS="src m m9 q mq9"
TESTS="src m m9 q mq9"
src() {
  case $1 in
    main) echo "$OLD" ;;
    src) echo "$SRC" ;;
    *) echo "$SRC+$P/$1.patch" ;;
  esac
}
specs="main=$(src main)"
for v in $VARIANTS; do specs="$specs $v=$(src $v) ${v}2=$(src $v)"; done
specs="$specs main2=$(src main)"
stage=$(mktemp -d)
tools/bench/make_ab_plugin.sh neighbors.delaunay $specs
cmake -S . -B build > /dev/null
cmake --build build -j2 --target flipflow_plugin_frnn_ab > /dev/null
mkdir -p "$stage/ab"
cp build/plugins/libflipflow_plugin_frnn_ab.so "$stage/ab/"
rm -rf plugins/frnn_ab
cmake -S . -B build > /dev/null
for v in $TESTS; do
  git checkout "$SRC" -- stages/neighbors/delaunay/
  [[ $v != src ]] && git apply "$P/$v.patch"
  cmake --build build -j2 --target flipflow_stage_neighbors > /dev/null
  mkdir -p "$stage/$v"
  cp build/plugins/libflipflow_stage_neighbors.so "$stage/$v/"
  git checkout HEAD -- stages/neighbors/delaunay/
done
git reset -q HEAD -- stages/neighbors/delaunay/
cmake --build build -j2 --target flipflow_stage_neighbors > /dev/null
for f in "$stage"/*/*.so; do patchelf --set-rpath '$ORIGIN/../../lib' "$f"; strip --strip-unneeded "$f"; done
mkdir -p "$dest"
tar cJf "$dest/so.tar.xz" -C "$stage" .
cp $P/run2.sh $P/ab2.yaml "$dest/"
rm -rf "$stage"
ls -la "$dest"
echo "plugin specs: $specs"
