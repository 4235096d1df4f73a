# Sourced by a GPU call script (bench/experiments/session*/s*.sh) run on the device machine from
# the repository root: the lines every such script began with, written once.
#
#   source tools/gpu/call_lib.sh NAME BUNDLE.tar.gz
#     unpacks the bundle to ./bundle (B), makes /tmp/NAME (O) with info.txt (I: the GPU, its
#     clocks and the bundle's commit), and defines:
#   pack                 $OUT/NAME.tgz from /tmp/NAME (written to a .part first, so a call cut
#                        by its time limit still brings back the last complete archive)
#   step TAG RC          a line "TAG rc=RC t=SECONDS" in info.txt, then pack
#   shadow V PLUGIN_DIR  a copy of the bundle at /tmp/sh-V/x whose plugins/ has PLUGIN_DIR's
#                        libraries in place of its own (the tests load plugins from their
#                        bundle; a variant library's rpath is $ORIGIN/../../lib, which the link
#                        /tmp/sh-V/lib provides); prints the copy's path
#   tests DIR LOG T...   the CUDA tests T... of the bundle at DIR ([long] left to the CPU suite),
#                        the output in LOG, its exit code at the end
set -u
SECONDS=0
call_name=$1
tar -xzf "$2"
B=$PWD/bundle
O=/tmp/$call_name
rm -rf "$O"
mkdir -p "$O"
I=$O/info.txt
{ nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv; head -1 "$B/.flipflow-bundle"; } > "$I"
pack() { (cd /tmp && tar -czf "$OUT/$call_name.tgz.part" "$call_name" && mv "$OUT/$call_name.tgz.part" "$OUT/$call_name.tgz"); }
step() { echo "$1 rc=$2 t=$SECONDS" >> "$I"; pack; }
shadow() {
  local S=/tmp/sh-$1
  rm -rf "$S"
  mkdir -p "$S/x"
  for d in bin lib tests plugins test-plugins pipelines; do [[ -e $B/$d ]] && cp -a "$B/$d" "$S/x/"; done
  cp "$B/.flipflow-bundle" "$S/x/" 2>/dev/null
  cp "$2"/*.so "$S/x/plugins/"
  ln -s "$S/x/lib" "$S/lib"
  echo "$S/x"
}
tests() {
  local dir=$1 log=$2
  shift 2
  (cd "$dir" && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout "${TEST_TIMEOUT:-150}" bin/run-tests "$@" > "$log" 2>&1
   echo "rc=$?" >> "$log")
}
