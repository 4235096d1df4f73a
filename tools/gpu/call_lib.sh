# Sourced by a GPU call script (bench/experiments/session*/s*.sh) run on the device machine from
# the repository root: the lines every such script began with, written once.
#
#   source tools/gpu/call_lib.sh NAME BUNDLE.tar.gz (or .tar.xz: a third the size, more room in the carry)
#     unpacks the bundle to ./bundle (B), makes /tmp/NAME (O) with info.txt (I: the GPU, its
#     clocks and the bundle's commit), and defines:
#   pack                 $OUT/NAME.tgz from /tmp/NAME (written to a .part first, so a call cut
#                        by its time limit still brings back the last complete archive)
#   step TAG RC          a line "TAG rc=RC t=SECONDS" in info.txt, then pack
#   shadow V PLUGIN_DIR  a copy of the bundle at /tmp/sh-V/x whose plugins/ has PLUGIN_DIR's
#                        libraries in place of its own (the tests load plugins from their
#                        bundle; a variant library's rpath is $ORIGIN/../../lib, which the link
#                        /tmp/sh-V/lib provides); prints the copy's path
#   variant V TAR        a stage plugin variant (TAR: its libraries, tar.xz) unpacked to /tmp/p-V, and
#                        its shadow bundle (shadow above); prints the bundle's path, for D[V]
#   rounds "V..." A...   three interleaved rounds (ROUNDS to change) of bench_abp V rK A... over the
#                        bundles V... (tags r1, r2, ...)
#   errors_test V        test_overlap_correct_errors on the bundle ${D[V]} (errors.txt), then step errors
#   tests DIR LOG T...   the CUDA tests T... of the bundle at DIR ([long] left to the CPU suite),
#                        the output in LOG, its exit code at the end
#   suite DIR [LIMIT]    every CUDA test of the bundle at DIR in six groups at once (the slow
#                        executables first, one to a group; logs tests-0..5.txt, LIMIT s each,
#                        default 280), then test_out_of_memory alone (tests-oom.txt); a summary
#                        line in info.txt. Jobs started before it run beside it.
#   bench_abp V TAG A... `pipeline bench` of bench-abp.yaml on CUDA with A..., from the bundle
#                        ${D[V]} (D: the script's bundles by name, declared before the call); its
#                        result lines in ab.txt as "V TAG: ...", then step V-TAG
#   correction_tests V...  the correction's six CUDA test executables (test_overlap_correct_cpu_cuda,
#                        _correct, _walls, _determinism, test_cpu_cuda_bits, test_device_decisions)
#                        on each bundle ${D[V]} at once (logs V-tests.txt, TEST_TIMEOUT s, default
#                        200); a "V: P PASS, F FAIL" line each in info.txt, then step variant-tests
#   ncu_correction N...  ncu of overlap_correct's kernel at N particles (one launch 120 steps in, L1/L2
#                        hit rates, per-instruction stall sampling): ncu-details-N.txt, ncu-sass-N.csv.xz;
#                        NCU_KERNEL (a regex, default correct_kernel), NCU_LAUNCHES (default 1) and
#                        NCU_EXTRA (more ncu options) change what it profiles
#   ncu_profile TAG DIR N  the same profile of bench-abp at N particles from the bundle at DIR (a
#                        variant's, ${D[V]}), its files named by TAG: ncu-details-TAG.txt, ...
#   sweep_abp TAG        issue 20's sweep row: 64 runs of bench-abp 2^14 at once on the bundle B
#                        (`pipeline sweep --in-process --concurrent 64`, 5 000 steps each); its two
#                        last lines in sweep.txt as "sweep TAG: ...", then step sweepTAG
#   delaunay_tests V     the Delaunay stages' CUDA test executables and those that check their bits
#                        (CPU == CUDA, rollback, graph capture, device decisions) on the bundle
#                        ${D[V]} (log V-tests.txt, TEST_TIMEOUT s, default 240); a "V: P PASS, F FAIL"
#                        line in info.txt, then step V-tests
#   variant_tests V T... the CUDA test executables T... on the bundle ${D[V]} (log V-tests.txt,
#                        TEST_TIMEOUT s, default 200); a "V: P PASS, F FAIL" line in info.txt, then
#                        step V-tests (session 44's calls 11 and 13 wrote these lines out)
#   timelines N...       CUPTI timelines of bench-abp at each N (tools/gpu_trace; 200 steps after
#                        20, 60 at 2^20): trace-N.csv.xz and summarize.py's typical step and
#                        groups (trace-N-summary.txt, trace-N-group2.txt), then step trace-N;
#                        TRACE_PIPELINE (a shipped pipeline's stem, default bench-abp) and
#                        TRACE_MARKER (the step's first kernel, summarize.py's --step-marker,
#                        default abp; OverdampedStep for the brownian pipelines) for another
#                        pipeline, whose files are then named trace-PIPELINE-N*
#   host_waits N...      the host's side of bench-abp's step at each N (tools/gpu/host_waits.c, preloaded;
#                        400 steps after 20): host_waits.py's summary in host-waits.txt (the host's
#                        own time a step, its waits, the typical step's calls), the records in
#                        hw-N.txt.xz, then step hw-N
#   host_profile N...    where the host's own time goes in bench-abp's step at each N (tools/gpu/
#                        host_profile.c, preloaded: stacks sampled on the CPU-time clock during
#                        `pipeline run` of HP_STEPS steps, default 100 000): the samples in
#                        hp-N.txt.xz (symbolise them here against the same bundle:
#                        host_profile.py hp-N.txt --root bundle), a first reading in
#                        host-profile-N.txt, then step hp-N
#   issue20_rows SIZES   issue 20's rows in one call (~420 s; carry gpu-carry/hoomd-kit.tgz =
#                        ../shared/peers-gpu/hoomd as hoomd-kit/, gpu-carry/peers-bundle.tar.gz =
#                        ../shared/peers-gpu/bundle): HOOMD-blue built on the host's cores while
#                        the whole CUDA suite runs; HOOMD-blue's ABP + WCA row at 2^14 and 2^20,
#                        bench-abp at SIZES (comma-separated) right after and at 2^20 after
#                        3 000 steps (bench_abp main: D[main] must be declared), Carter side by
#                        side (bench/carter_side_by_side.sh small) and the sweep row
set -u
SECONDS=0
call_name=$1
tar -xf "$2"  # gzip or xz (tar finds which)
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
variant() {
  local d=/tmp/p-$1
  rm -rf "$d"
  mkdir -p "$d" && tar -xJf "$2" -C "$d" && shadow "$1" "$d"
}
tests() {
  local dir=$1 log=$2
  shift 2
  (cd "$dir" && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout "${TEST_TIMEOUT:-150}" bin/run-tests "$@" > "$log" 2>&1
   echo "rc=$?" >> "$log")
}
suite() {
  local dir=$1 limit=${2:-280} g
  local slow="test_hard_sphere_eos test_decomposition_delaunay test_checkpoint test_checkpoint_signals test_overlap_correct_cpu_cuda test_rollback_stress test_tran_aggregation"
  local rest all pids=()
  rest=$(cd "$dir/bin" && ls test_* | grep -v '^test_out_of_memory$' | grep -v -x -F "$(echo $slow | tr ' ' '\n')")
  all=$(echo $slow $rest | tr ' ' '\n' | awk 'NF {print NR % 6, $0}')
  for g in 0 1 2 3 4 5; do
    TEST_TIMEOUT=$limit tests "$dir" "$O/tests-$g.txt" $(echo "$all" | awk -v g=$g '$1 == g {print $2}') &
    pids+=($!)
  done
  wait "${pids[@]}"
  TEST_TIMEOUT=40 tests "$dir" "$O/tests-oom.txt" test_out_of_memory
  local logs="$O/tests-[0-5].txt $O/tests-oom.txt"
  { echo "suite: $(cat $logs | grep -c "^PASS") PASS, $(cat $logs | grep -c "^FAIL") FAIL"; cat $logs | grep "^FAIL";
    grep -h "^rc=" $logs | tr '\n' ' '; echo; } >> "$I"
}
bench_abp() {
  local v=$1 tag=$2
  shift 2
  timeout "${BENCH_TIMEOUT:-120}" "${D[$v]}/bin/pipeline" bench "${D[$v]}/pipelines/bench-abp.yaml" --device cuda "$@" 2>&1 |
    grep -E "^[0-9]|overlap_correct/iter|host's own|rror" | sed "s/^/$v $tag: /" >> "$O/ab.txt"
  step "$v-$tag" "${PIPESTATUS[0]}"
}
correction_tests() {
  local v
  for v in "$@"; do
    TEST_TIMEOUT=${TEST_TIMEOUT:-200} tests "${D[$v]}" "$O/$v-tests.txt" test_overlap_correct_cpu_cuda test_overlap_correct \
      test_overlap_correct_walls test_overlap_correct_determinism test_cpu_cuda_bits test_device_decisions &
  done
  wait
  for v in "$@"; do echo "$v: $(grep -c "^PASS" "$O/$v-tests.txt") PASS, $(grep -c "^FAIL" "$O/$v-tests.txt") FAIL" >> "$I"; done
  step variant-tests 0
}
ncu_profile() {
  local tag=$1 bundle=$2 n=$3 ncu
  ncu=$(command -v ncu || ls /usr/local/cuda*/bin/ncu /opt/nvidia/nsight-compute/*/ncu 2>/dev/null | head -n 1)
  echo "ncu: ${ncu:-none}" >> "$I"
  timeout 180 "$ncu" --target-processes all --clock-control none -k regex:"${NCU_KERNEL:-correct_kernel}" \
    --launch-skip 120 --launch-count "${NCU_LAUNCHES:-1}" ${NCU_EXTRA:-} \
    --section LaunchStats --section Occupancy --section SchedulerStats --section WarpStateStats \
    --section InstructionStats --section SpeedOfLight --section SourceCounters --section MemoryWorkloadAnalysis \
    -f -o "$O/oc-$tag" "$bundle/bin/pipeline" bench "$bundle/pipelines/bench-abp.yaml" --device cuda --sizes "$n" \
    --steps 1 --warmup 125 > "$O/ncu-run-$tag.txt" 2>&1
  step "ncu-$tag" $?
  [[ -f $O/oc-$tag.ncu-rep ]] || return 0
  "$ncu" -i "$O/oc-$tag.ncu-rep" --page details > "$O/ncu-details-$tag.txt" 2>&1
  "$ncu" -i "$O/oc-$tag.ncu-rep" --page source --csv --print-source sass 2>&1 | xz > "$O/ncu-sass-$tag.csv.xz"
  rm -f "$O/oc-$tag.ncu-rep"
  step "ncu-export-$tag" 0
}
ncu_correction() {
  local n
  for n in "$@"; do ncu_profile "$n" "$B" "$n"; done
}
sweep_abp() {
  rm -rf /tmp/sw
  timeout 60 "$B/bin/pipeline" sweep "$B/pipelines/bench-abp.yaml" --device cuda --set system.N=16384 \
    --set run.steps=5000 --replicas 64 --out /tmp/sw --concurrent 64 --in-process 2>&1 | tail -2 |
    sed "s/^/sweep $1: /" >> "$O/sweep.txt"
  step "sweep$1" "${PIPESTATUS[0]}"
}
timelines() {
  local n st t
  for n in "$@"; do
    st=200
    [[ $n == 1048576 ]] && st=60
    t=${TRACE_PIPELINE:+$TRACE_PIPELINE-}$n  # bench-abp's files keep their names
    CUDA_INJECTION64_PATH=$B/lib/libflipflow_gpu_trace.so FLIPFLOW_GPU_TRACE=/tmp/trace-$t.csv timeout 100 \
      "$B/bin/pipeline" bench "$B/pipelines/${TRACE_PIPELINE:-bench-abp}.yaml" --device cuda --sizes "$n" --steps $st \
      --warmup 20 > "$O/trace-run-$t.txt" 2>&1
    local summarize=(python3 tools/gpu_trace/summarize.py /tmp/trace-$t.csv --step-marker "${TRACE_MARKER:-abp}" --skip 25
      --count $((st - 10)))
    "${summarize[@]}" > "$O/trace-$t-summary.txt" 2>&1
    "${summarize[@]}" --group 2 > "$O/trace-$t-group2.txt" 2>&1
    xz -c /tmp/trace-$t.csv > "$O/trace-$t.csv.xz"
    step "trace-$t" $?
  done
}
issue20_rows() {
  local build
  tar -xzf gpu-carry/hoomd-kit.tgz
  (OUT=$O HOOMD_JOBS=16 nice -n 19 bash hoomd-kit/build.sh 420 > "$O/hoomd-build.txt" 2>&1
   echo "build rc=$? t=$SECONDS" >> "$O/hoomd-build.txt") &
  build=$!
  suite "$B" 280
  step suite 0
  wait $build
  step hoomd-build 0
  ((SECONDS < 440)) && {
    OUT=$O timeout $((470 - SECONDS)) bash hoomd-kit/run.sh --sizes 16384 1048576 --dts 2e-3 --max-seconds 8 \
      > "$O/hoomd-run.txt" 2>&1
    step hoomd $?
  }
  bench_abp main hoomd-row --sizes "$1" --steps 200 --warmup 20
  bench_abp main late --sizes 1048576 --steps 100 --warmup 3000
  mkdir -p /tmp/pb && tar -xzf gpu-carry/peers-bundle.tar.gz -C /tmp/pb
  ((SECONDS < 500)) && {
    timeout $((560 - SECONDS)) bash bench/carter_side_by_side.sh "$B" /tmp/pb/bundle "$O/carter" small > "$O/carter-run.txt" 2>&1
    step carter $?
  }
  ((SECONDS < 540)) && sweep_abp 1
  return 0
}
host_waits() {
  local n
  [[ -f /tmp/host_waits.so ]] || gcc -O2 -shared -fPIC tools/gpu/host_waits.c -o /tmp/host_waits.so -ldl
  for n in "$@"; do
    LD_PRELOAD=/tmp/host_waits.so HOST_WAITS_OUT=/tmp/hw-$n.txt timeout 60 "$B/bin/pipeline" bench \
      "$B/pipelines/bench-abp.yaml" --device cuda --sizes "$n" --steps 400 --warmup 20 > "$O/hw-run-$n.txt" 2>&1
    python3 tools/gpu/host_waits.py /tmp/hw-$n.txt 20 400 >> "$O/host-waits.txt" 2>&1
    xz -c /tmp/hw-$n.txt > "$O/hw-$n.txt.xz"
    step "hw-$n" 0
  done
}
host_profile() {
  local n
  [[ -f /tmp/host_profile.so ]] || gcc -O2 -shared -fPIC tools/gpu/host_profile.c -o /tmp/host_profile.so -ldl
  for n in "$@"; do
    timeout 120 env LD_PRELOAD=/tmp/host_profile.so HOST_PROFILE_OUT=/tmp/hp-$n.txt "$B/bin/pipeline" run \
      "$B/pipelines/bench-abp.yaml" --device cuda --set system.N=$n --set run.steps=${HP_STEPS:-100000} \
      --out /tmp/hp-run-$n --force > "$O/hp-run-$n.txt" 2>&1
    local rc=$?
    python3 tools/gpu/host_profile.py /tmp/hp-$n.txt --root "$B" >> "$O/host-profile-$n.txt" 2>&1
    xz -c /tmp/hp-$n.txt > "$O/hp-$n.txt.xz"
    step "hp-$n" $rc
  done
}
delaunay_tests() {
  TEST_TIMEOUT=${TEST_TIMEOUT:-240} variant_tests "$1" test_delaunay_lawson test_delaunay_flip \
    test_delaunay_detect_inversion test_delaunay_tries test_cpu_cuda_bits test_boids_delaunay test_rollback \
    test_rollback_restores test_device_decisions test_graph_capture test_neighbors_delaunay test_delaunay_check
}
variant_tests() {
  local v=$1
  shift
  TEST_TIMEOUT=${TEST_TIMEOUT:-200} tests "${D[$v]}" "$O/$v-tests.txt" "$@"
  echo "$v: $(grep -c "^PASS" "$O/$v-tests.txt") PASS, $(grep -c "^FAIL" "$O/$v-tests.txt") FAIL" >> "$I"
  step "$v-tests" 0
}
rounds() {
  local vs=$1 r v
  shift
  for r in $(seq 1 "${ROUNDS:-3}"); do for v in $vs; do bench_abp "$v" "r$r" "$@"; done; done
}
errors_test() {
  tests "${D[$1]}" "$O/errors.txt" test_overlap_correct_errors
  step errors 0
}
