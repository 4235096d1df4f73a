#!/bin/bash
# Builds what run.sh needs into $DEST (default /work/main/gpu-carry/frnn7): so.tar.xz with
#   ab/      one plugin with every variant as a stage frnn_ab.<v> (tools/bench/make_ab_plugin.sh),
#            each listed twice (<v> and <v>2: the second round, in reverse order in ab.yaml)
#   <v>/     the neighbors stage plugin with bench/experiments/frnn7/<v>.patch applied, for the
#            CUDA test of each variant (test_neighbors_delaunay with FLIPFLOW_PLUGIN_PATH=<v>:...)
# each .so with rpath $ORIGIN/../../lib, and run.sh and ab.yaml beside it. Run from the worktree
# root with a clean stages/neighbors/delaunay/ and no plugins/frnn_ab.
#   BASE: a commit whose stages/neighbors/delaunay/ is main's (the patches' base);
#   BASE6: frnn6's base (75cd2a8) for frnn6's fm4bs and this folder's fm4b* variants.
set -euo pipefail
dest=${DEST:-/work/main/gpu-carry/frnn7}
P=bench/experiments/frnn7
BASE=${BASE:-09b83dc}
BASE6=75cd2a8
VARIANTS=${VARIANTS:-"fm4bs fm4bsc fm4bsci fm4bscq fm4bsc10 fm4bc cv cvs cvj cvjs cvis"}
TESTS=${TESTS:-"fm4bsc fm4bsci fm4bscq fm4bsc10 fm4bc cv cvs cvj cvjs cvis"}
src() {  # the make_ab_plugin source of variant $1
  case $1 in
    main) echo "$BASE" ;;
    fm4bs) echo "$BASE6+bench/experiments/frnn6/fm4bs.patch" ;;
    fm*) echo "$BASE6+$P/$1.patch" ;;
    *) echo "$BASE+$P/$1.patch" ;;
  esac
}
specs="main=$(src main)"
for v in $VARIANTS; do specs="$specs $v=$(src $v)"; done
for v in $VARIANTS; do specs="$specs ${v}2=$(src $v)"; done
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
  base=$BASE
  [[ $v == fm* ]] && base=$BASE6
  git checkout "$base" -- stages/neighbors/delaunay/
  git apply "$P/$v.patch"
  cmake --build build -j2 --target flipflow_stage_neighbors > /dev/null
  mkdir -p "$stage/$v"
  cp build/plugins/libflipflow_stage_neighbors.so "$stage/$v/"
  git checkout HEAD -- stages/neighbors/delaunay/
done
cmake --build build -j2 --target flipflow_stage_neighbors > /dev/null
for f in "$stage"/*/*.so; do patchelf --set-rpath '$ORIGIN/../../lib' "$f"; strip --strip-unneeded "$f"; done
mkdir -p "$dest"
tar cJf "$dest/so.tar.xz" -C "$stage" .
cp $P/run.sh $P/ab.yaml "$dest/"
rm -rf "$stage"
ls -la "$dest"
echo "plugin specs: $specs"
