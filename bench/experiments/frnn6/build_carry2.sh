#!/bin/bash
# Builds what gpu-run-2.sh needs into $DEST (default /work/main/gpu-carry/frnn6): so2.tar.xz with
#   ab/      the A/B plugin of AB_SPECS (tools/bench/make_ab_plugin.sh specs: main=75cd2a8 src=HEAD v=HEAD+patch ...)
#   src/     the neighbors stage plugin of the worktree as it is (the branch's source)
#   <v>/     the same with bench/experiments/frnn6/<v>.patch applied, for each v in STAGES
# each .so with rpath $ORIGIN/../../lib, and gpu-run-2.sh and ab2.yaml beside it. Run from the
# worktree root with a clean stages/neighbors/delaunay/.
set -euo pipefail
dest=${DEST:-/work/main/gpu-carry/frnn6}
P=bench/experiments/frnn6
stage=$(mktemp -d)
tools/bench/make_ab_plugin.sh neighbors.delaunay $AB_SPECS
cmake -S . -B build > /dev/null
cmake --build build -j2 --target flipflow_plugin_frnn_ab > /dev/null
mkdir -p "$stage/ab"
cp build/plugins/libflipflow_plugin_frnn_ab.so "$stage/ab/"
rm -rf plugins/frnn_ab
cmake -S . -B build > /dev/null
cmake --build build -j2 --target flipflow_stage_neighbors > /dev/null
mkdir -p "$stage/src"
cp build/plugins/libflipflow_stage_neighbors.so "$stage/src/"
for v in ${STAGES:-}; do
  git apply "$P/$v.patch"
  cmake --build build -j2 --target flipflow_stage_neighbors > /dev/null
  mkdir -p "$stage/$v"
  cp build/plugins/libflipflow_stage_neighbors.so "$stage/$v/"
  git checkout -- stages/neighbors/delaunay/
done
cmake --build build -j2 --target flipflow_stage_neighbors > /dev/null
for f in "$stage"/*/*.so; do patchelf --set-rpath '$ORIGIN/../../lib' "$f"; strip --strip-unneeded "$f"; done
mkdir -p "$dest"
tar cJf "$dest/so2.tar.xz" -C "$stage" .
cp $P/gpu-run-2.sh $P/ab2.yaml "$dest/"
rm -rf "$stage"
ls -la "$dest"
