#!/usr/bin/env bash
# test_sdk_example (tests/CMakeLists.txt): flipflow as an SDK, the way a user outside the
# repository meets it. Installs this build into a temporary prefix (and checks that every
# installed header's includes are installed too), configures and builds examples/chiral_abp
# against that prefix alone (never the build or source tree), runs the example's test through
# ctest (flipflow_add_plugin builds its test_chiral_abp.cpp with the installed stage driver),
# runs its pipeline with the installed `pipeline` and the example's plugin, then checks that a
# configure without Catch2 names that test as not built and that FLIPFLOW_PLUGIN_CUDA=OFF builds a
# plugin of CPU stages alone.
#
#   tests/sdk/build_example.sh <flipflow build dir> [<flipflow source dir>] [<cmake>]
#
# With CUDA in the build the example compiles its CUDA source too (the package enables CUDA);
# its test also runs on the GPU when there is one. FLIPFLOW_SDK_KEEP=1 keeps the temporary folder.
set -euo pipefail
build=$(cd "$1" && pwd)
src=$(cd "${2:-$(dirname "$0")/../..}" && pwd)
cmake=${3:-cmake}
example=$src/examples/chiral_abp

work=$(mktemp -d "${TMPDIR:-/tmp}/flipflow-sdk.XXXXXX")
if [[ ${FLIPFLOW_SDK_KEEP:-0} == 1 ]]; then echo "keeping $work"; else trap 'rm -rf "$work"' EXIT; fi
prefix=$work/prefix
step() { printf '\n== %s (%ds)\n' "$*" "$SECONDS"; }

step "install $build into $prefix"
"$cmake" --install "$build" --prefix "$prefix" >"$work/install.log"
for f in bin/pipeline lib/libflipflow.so lib/cmake/flipflow/flipflowConfig.cmake \
         share/flipflow/sdk/plugin_entry.cpp include/core/stage/stage_registration.h \
         include/stages/neighbors/pair_force.h include/flipflow/tests/support/stage_driver.h; do
  [[ -e $prefix/$f ]] || { echo "FAIL: the install lacks $f"; exit 1; }
done
ls "$prefix/lib/flipflow/plugins"

step "every quoted include of an installed header is installed"
# Resolved as the compiler would for a plugin or its test: beside the header, then P/include
# (flipflow::core), then P/include/flipflow/tests (the tests flipflow_add_plugin builds).
missing=0
while IFS= read -r -d '' h; do
  while IFS= read -r inc; do
    [[ -e $(dirname "$h")/$inc || -e $prefix/include/$inc || -e $prefix/include/flipflow/tests/$inc ]] ||
      { echo "FAIL: ${h#"$prefix"/} includes \"$inc\", which is not installed"; missing=1; }
  done < <(sed -n 's/^[[:space:]]*#[[:space:]]*include[[:space:]]*"\([^"]*\)".*/\1/p' "$h")
done < <(find "$prefix/include" -type f \( -name '*.h' -o -name '*.cuh' \) -print0)
((missing == 0)) || exit 1

step "configure examples/chiral_abp against $prefix only"
# Nothing from the environment may point find_package elsewhere, nor the package registry.
unset CMAKE_PREFIX_PATH flipflow_DIR flipflow_ROOT FLIPFLOW_ROOT FLIPFLOW_PLUGIN_PATH
"$cmake" -S "$example" -B "$work/example" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF \
  -DCMAKE_FIND_USE_SYSTEM_PACKAGE_REGISTRY=OFF >"$work/configure.log" 2>&1 ||
  { cat "$work/configure.log"; exit 1; }
found=$(sed -n 's/^flipflow_DIR:PATH=//p' "$work/example/CMakeCache.txt")
echo "flipflow_DIR = $found"
[[ $found == "$prefix/lib/cmake/flipflow" ]] || { echo "FAIL: found flipflow at '$found', not in $prefix"; exit 1; }
grep -q "CMAKE_CUDA_COMPILER:" "$work/example/CMakeCache.txt" && echo "CUDA enabled by the package"

step "build the example"
"$cmake" --build "$work/example" -j "${FLIPFLOW_SDK_JOBS:-2}" >"$work/build.log" 2>&1 ||
  { cat "$work/build.log"; exit 1; }
plugin=$work/example/plugins/libflipflow_plugin_chiral_abp.so
[[ -f $plugin ]] || { echo "FAIL: no $plugin"; exit 1; }
# The example's binaries use the installed core, not the build tree's.
for bin in "$plugin" "$work/example/test_chiral_abp"; do
  core=$(ldd "$bin" | awk '/libflipflow\.so/ {print $3}')
  echo "$(basename "$bin") -> $core"
  [[ $core == "$prefix/lib/libflipflow.so" ]] || { echo "FAIL: $(basename "$bin") loads '$core'"; exit 1; }
done

step "the example's test, through ctest"
ctest=$(dirname "$cmake")/ctest
[[ -x $ctest ]] || ctest=ctest
"$ctest" --test-dir "$work/example" --output-on-failure | tee "$work/ctest.log"
grep -q "1/1 Test #1: test_chiral_abp .* Passed" "$work/ctest.log" ||
  { echo "FAIL: ctest did not run and pass test_chiral_abp alone"; exit 1; }

step "pipeline run chiral.yaml (installed pipeline, FLIPFLOW_PLUGIN_PATH=<example build>/plugins)"
cd "$work"
FLIPFLOW_PLUGIN_PATH=$work/example/plugins "$prefix/bin/pipeline" stages | grep chiral_abp.integrate
FLIPFLOW_PLUGIN_PATH=$work/example/plugins "$prefix/bin/pipeline" run "$example/pipelines/chiral.yaml" \
  --out "$work/run" 2>&1 | tee "$work/run.log"
[[ -s $work/run/chiral.h5 ]] || { echo "FAIL: the run wrote no chiral.h5"; exit 1; }

step "configure again without Catch2 and with FLIPFLOW_PLUGIN_CUDA=OFF, build the plugin"
# Two options of the package in one configure (each is a few seconds): a warning must name the
# test left out, and the plugin, rebuilt without CUDA, must load with its CPU build alone.
"$cmake" "$work/example" -DCMAKE_DISABLE_FIND_PACKAGE_Catch2=ON -DFLIPFLOW_PLUGIN_CUDA=OFF \
  >"$work/reconfigure.log" 2>&1 || { cat "$work/reconfigure.log"; exit 1; }
grep -A6 "CMake Warning" "$work/reconfigure.log"
grep -qF "$example/test_chiral_abp.cpp" "$work/reconfigure.log" ||
  { echo "FAIL: the configure without Catch2 did not name test_chiral_abp.cpp"; exit 1; }
"$cmake" --build "$work/example" -j "${FLIPFLOW_SDK_JOBS:-2}" >"$work/build-cpu.log" 2>&1 ||
  { cat "$work/build-cpu.log"; exit 1; }
if grep -q "Building CUDA" "$work/build-cpu.log"; then
  echo "FAIL: with FLIPFLOW_PLUGIN_CUDA=OFF the plugin still compiles CUDA"; exit 1
fi
FLIPFLOW_PLUGIN_PATH=$work/example/plugins "$prefix/bin/pipeline" describe chiral_abp.integrate |
  tee "$work/describe.log" | grep "backends:"
grep -q "backends: cpu$" "$work/describe.log" ||
  { echo "FAIL: the CPU-only plugin does not declare exactly the CPU backend"; exit 1; }
step "passed"
