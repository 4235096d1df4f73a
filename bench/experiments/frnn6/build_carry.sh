#!/bin/bash
# Builds what gpu-run.sh needs into $1 (default /work/main/gpu-carry/frnn6): the A/B plugin
# (tools/bench/make_ab_plugin.sh: every variant a stage frnn_ab.<v>) and, per variant, the neighbors stage
# plugin with the patch applied (for test_neighbors_delaunay), each .so with rpath $ORIGIN/../../lib
# (it sits in <bundle>/frnn6/<v>/), packed in so.tar.xz. Run from the worktree root, clean tree.
set -euo pipefail
dest=${1:-/work/main/gpu-carry/frnn6}
shift || true
P=bench/experiments/frnn6
VARIANTS=${VARIANTS:-"fmb fmrb fm sqb fm2b fmnb fmb12 fmr fmrb10 fmr2b fmrbs fmra fmras"}
stage=$(mktemp -d)
specs="main=HEAD"
for v in $VARIANTS; do specs="$specs $v=HEAD+$P/$v.patch"; done
specs="$specs main2=HEAD"
tools/bench/make_ab_plugin.sh neighbors.delaunay $specs
cmake -S . -B build > /dev/null
cmake --build build -j2 --target flipflow_plugin_frnn_ab > /dev/null
mkdir -p "$stage/ab"
cp build/plugins/libflipflow_plugin_frnn_ab.so "$stage/ab/"
rm -rf plugins/frnn_ab
cmake -S . -B build > /dev/null
for v in $VARIANTS; do
  git apply "$P/$v.patch"
  cmake --build build -j2 --target flipflow_stage_neighbors > /dev/null
  mkdir -p "$stage/$v"
  cp build/plugins/libflipflow_stage_neighbors.so "$stage/$v/"
  git checkout -- stages/neighbors/delaunay/
done
cmake --build build -j2 --target flipflow_stage_neighbors > /dev/null
for f in "$stage"/*/*.so; do patchelf --set-rpath '$ORIGIN/../../lib' "$f"; strip --strip-unneeded "$f"; done
mkdir -p "$dest"
tar cJf "$dest/so.tar.xz" -C "$stage" .
cp $P/gpu-run.sh $P/frnn-ab.yaml "$dest/"
rm -rf "$stage"
ls -la "$dest"
