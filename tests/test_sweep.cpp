// `pipeline sweep` end to end, on the CPU: a 2 x 2 grid with 2 replicas makes 8 folders and an
// index whose rows match what each run recorded (/parameters: the --set arguments and the
// effective pipeline); a run of the sweep equals the same `pipeline run --set ...` in every
// H5MD dataset; a bad grid key or value exits 2 naming it and writes nothing; a run that fails
// leaves the others running and its row says why; a sweep killed mid-way (its runs get SIGTERM
// and checkpoint) and run again finishes with the same outputs as one never interrupted;
// --concurrent 2 (child processes, or threads with --in-process) gives the same outputs as
// --concurrent 1. FLIPFLOW_TEST_DEVICE=cuda runs the [device] cases on the GPU (skipped without
// one): there --concurrent 2 shares the GPU through CUDA MPS when it starts, and on a machine
// with two or more GPUs a sweep goes to every GPU (child processes, or threads with --in-process)
// with the outputs of one.
#include <catch2/catch.hpp>
#include <hdf5.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>

#include "core/backend/device.h"
#include "core/io/h5md_writer.h"
#include "support/cli.h"
#include "support/h5md_files.h"

extern char** environ;

namespace fs = std::filesystem;

namespace {

using namespace ff::test;  // pipeline_exe, repo_file, datasets, require_same_h5md, ...

std::string device() { return ff::test::test_device(); }
bool device_available() { return ff::test::test_device_available("pipeline sweep on CUDA"); }

fs::path fresh_dir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("ff_sweep_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  return d;
}

ff::test::CommandResult pipeline(const std::string& args) {
  return ff::test::run_command(pipeline_exe() + " " + args,
                               fs::temp_directory_path() / ("ff_sweep_" + std::to_string(::getpid()) + ".log"));
}

// ---- the sweep of these tests: brownian.yaml, 2 x 2 grid, 2 replicas ----

const std::vector<std::string> kSets = {"run.steps=60", "step.observe.h5md.every=20", "step.observe.msd.every=20",
                                        "step.observe.progress.every=100000"};
const std::vector<std::string> kGrid = {"step.brownian.integrate.D=0.5,2", "system.N=50,80"};

std::string sweep_args(const fs::path& out, const std::vector<std::string>& extra_sets = {}) {
  std::string a = "sweep " + repo_file("pipelines/brownian.yaml").string() + " --device " + device() + " --replicas 2 --out " +
                  out.string();
  for (auto& s : kSets) a += " --set '" + s + "'";
  for (auto& s : extra_sets) a += " --set '" + s + "'";
  for (auto& g : kGrid) a += " --grid '" + g + "'";
  return a;
}

// ---- reading outputs ----

std::vector<std::string> csv_split(const std::string& line) {
  std::vector<std::string> out;
  std::string cur;
  bool q = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (q && c == '"' && i + 1 < line.size() && line[i + 1] == '"') cur += '"', ++i;
    else if (c == '"') q = !q;
    else if (c == ',' && !q) out.push_back(cur), cur.clear();
    else cur += c;
  }
  out.push_back(cur);
  return out;
}

// The index as rows of column -> value.
std::vector<std::map<std::string, std::string>> read_index(const fs::path& file) {
  std::ifstream in(file);
  std::string line;
  std::vector<std::map<std::string, std::string>> rows;
  REQUIRE(std::getline(in, line));
  const auto header = csv_split(line);
  while (std::getline(in, line)) {
    const auto f = csv_split(line);
    REQUIRE(f.size() == header.size());
    std::map<std::string, std::string> row;
    for (std::size_t i = 0; i < f.size(); ++i) row[header[i]] = f[i];
    rows.push_back(row);
  }
  return rows;
}

// Every run of sweep `a` has the same trajectory.h5 datasets as in sweep `b`.
void require_same_sweep(const fs::path& a, const fs::path& b) {
  const auto rows = read_index(a / "index.csv");
  REQUIRE(rows.size() == 8);
  for (auto& row : rows) CHECK(require_same_h5md(a / row.at("folder") / "trajectory.h5",
                                                 b / row.at("folder") / "trajectory.h5") >= 6);
}

// A sweep made once and shared by the tests, removed at exit.
struct SharedSweep {
  fs::path dir;
  ~SharedSweep() {
    std::error_code ec;
    if (!dir.empty()) fs::remove_all(dir, ec);
  }
};

const fs::path& shared_sweep(SharedSweep& s, const std::string& name, const std::vector<std::string>& sets) {
  if (s.dir.empty()) {
    const fs::path out = fresh_dir(name);
    require_success(pipeline(sweep_args(out, sets)));
    s.dir = out;
  }
  return s.dir;
}

// The uninterrupted sweep the others are compared with.
const fs::path& reference_sweep() {
  static SharedSweep s;
  return shared_sweep(s, "reference", {});
}

// Longer runs with checkpoints, so that a kill lands inside a run; and their uninterrupted sweep.
const std::vector<std::string> kLonger = {"run.steps=3000", "run.checkpoint={every: 100, keep: 2}"};
const fs::path& longer_reference_sweep() {
  static SharedSweep s;
  return shared_sweep(s, "longer_reference", kLonger);
}

pid_t spawn(const std::string& args, const fs::path& log) {
  const std::string cmd = "exec " + pipeline_exe() + " " + args + " > " + log.string() + " 2>&1";
  pid_t pid = 0;
  const char* argv[] = {"/bin/sh", "-c", cmd.c_str(), nullptr};
  // In a process group of its own, as a shell starts a command: kill(-pid) then reaches the sweep
  // and its runs, as Ctrl-C in a terminal does.
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attr, 0);
  const int rc = posix_spawn(&pid, "/bin/sh", nullptr, &attr, const_cast<char* const*>(argv), environ);
  posix_spawnattr_destroy(&attr);
  REQUIRE(rc == 0);
  return pid;
}

}  // namespace

TEST_CASE("sweep: a 2 x 2 grid with 2 replicas makes 8 folders; the index matches each run's /parameters",
          "[sweep][device]") {
  if (!device_available()) return;
  const fs::path out = reference_sweep();
  const auto rows = read_index(out / "index.csv");
  REQUIRE(rows.size() == 8);
  std::size_t folders = 0;
  for (auto& e : fs::directory_iterator(out)) folders += e.is_directory();
  CHECK(folders == 8);
  std::map<std::string, int> combos;
  for (auto& row : rows) {
    INFO("row " << row.at("folder"));
    CHECK(row.at("status") == "done");
    CHECK(row.at("exit_code") == "0");
    CHECK(std::stod(row.at("steps_per_s")) > 0);
    const fs::path h5 = out / row.at("folder") / "trajectory.h5";
    REQUIRE(fs::exists(h5));
    const std::string overrides = parameter_text(h5, "/parameters/overrides");
    const std::string effective = parameter_text(h5, "/parameters/effective_pipeline");
    const std::string D = row.at("step.brownian.integrate.D"), N = row.at("system.N"), seed = row.at("seed");
    CHECK_THAT(overrides, Catch::Contains("step.brownian.integrate.D=" + D) && Catch::Contains("system.N=" + N) &&
                              Catch::Contains("run.seed=" + seed) && Catch::Contains("run.steps=60"));
    CHECK_THAT(effective, Catch::Contains("N: " + N) && Catch::Contains("seed: " + seed) &&
                              Catch::Contains("D: " + D));
    // The folder name says the same, and the replicas have the file's seed + 0 and + 1.
    CHECK(row.at("folder") == "D=" + D + "_N=" + N + "_seed=" + seed);
    CHECK((seed == "42" || seed == "43"));
    CHECK(row.at("replica") == (seed == "42" ? "0" : "1"));
    // The --set values every run shares have columns of their own.
    CHECK(row.at("run.steps") == "60");
    CHECK(row.at("step.observe.h5md.every") == "20");
    ++combos[D + "/" + N];
    // The run's frames have the grid's N.
    CHECK(datasets(h5).at("particles/all/position/value").shape[1] == std::stoul(N));
  }
  CHECK(combos.size() == 4);
  for (auto& kv : combos) CHECK(kv.second == 2);
}

TEST_CASE("sweep: a run equals the same `pipeline run --set ...`, bit for bit", "[sweep][device]") {
  if (!device_available()) return;
  const fs::path ref = reference_sweep();
  const fs::path alone = fresh_dir("alone");
  std::string args = "run " + repo_file("pipelines/brownian.yaml").string() + " --device " + device() + " --out " + alone.string();
  for (auto& s : kSets) args += " --set '" + s + "'";
  for (auto& s : {"step.brownian.integrate.D=2", "system.N=80", "run.seed=43"}) args += std::string(" --set '") + s + "'";
  require_success(pipeline(args));
  const fs::path swept = ref / "D=2_N=80_seed=43" / "trajectory.h5";
  CHECK(require_same_h5md(swept, alone / "trajectory.h5") >= 6);
  CHECK(parameter_text(swept, "/parameters/overrides") == parameter_text(alone / "trajectory.h5", "/parameters/overrides"));
  CHECK(parameter_text(swept, "/parameters/effective_pipeline") ==
        parameter_text(alone / "trajectory.h5", "/parameters/effective_pipeline"));
  fs::remove_all(alone);
}

TEST_CASE("sweep: on two or more GPUs the runs go to every GPU, as processes or threads, with the outputs of one GPU",
          "[sweep][device]") {
  if (!device_available()) return;
  const int gpus = ff::cuda_device_count();
  if (gpus < 2) {
    WARN("SKIPPED (" << gpus << " CUDA device(s)): spreading a sweep over GPUs needs 2 or more");
    return;
  }
  // One GPU (--gpus 0), then every GPU (the default): one run at a time on each.
  const fs::path one = fresh_dir("gpu0"), all = fresh_dir("gpus");
  require_success(pipeline(sweep_args(one) + " --gpus 0"));
  auto r = require_success(pipeline(sweep_args(all)));
  INFO(r.out);
  std::map<std::string, int> runs_on;
  for (auto& row : read_index(one / "index.csv")) CHECK(row.at("gpu") == "0");
  for (auto& row : read_index(all / "index.csv")) ++runs_on[row.at("gpu")];
  // 8 runs, the GPU with the fewest under way takes the next: every GPU gets one (up to 8).
  CHECK(int(runs_on.size()) == std::min(gpus, 8));
  require_same_sweep(all, one);
  // The same on threads of this process, two at once on each GPU: each run on its thread's GPU.
  const fs::path threads = fresh_dir("gpus_in_process");
  auto t = require_success(pipeline(sweep_args(threads) + " --in-process --concurrent 2"));
  INFO(t.out);
  CHECK_THAT(t.out, Catch::Contains("per GPU on " + std::to_string(gpus) + " GPUs"));
  std::map<std::string, int> threads_on;
  for (auto& row : read_index(threads / "index.csv")) ++threads_on[row.at("gpu")];
  CHECK(int(threads_on.size()) == std::min(gpus, 4));
  require_same_sweep(threads, one);
  fs::remove_all(one);
  fs::remove_all(all);
  fs::remove_all(threads);
}

TEST_CASE("sweep: a bad grid key or value exits 2 naming it, and writes nothing", "[sweep]") {
  const std::string file = repo_file("pipelines/brownian.yaml").string();
  struct Bad {
    std::string grid, expect;
  };
  for (const Bad& b : {Bad{"step.brownian.integrat.D=1,2", "no step entry with id 'brownian.integrat'"},
                       Bad{"step.brownian.integrate.D=1,abc", "(value 'abc')"},
                       Bad{"step.brownian.integrate.nosuch=1,2", "nosuch"},
                       Bad{"sytem.N=10,20", "unknown section 'sytem'"}, Bad{"system.N=10,,20", "empty value"},
                       Bad{"system.N", "expected KEY.PATH=V1,V2"}}) {
    INFO("--grid " << b.grid);
    const fs::path out = fresh_dir("bad");
    auto r = pipeline("sweep " + file + " --device cpu --set run.steps=10 --grid system.N=10,20 --grid '" + b.grid +
                      "' --out " + out.string());
    INFO(r.out);
    CHECK(r.code == 2);
    CHECK_THAT(r.out, Catch::Contains("--grid " + b.grid.substr(0, b.grid.find('=') == std::string::npos
                                                                      ? b.grid.size()
                                                                      : b.grid.find('='))) &&
                          Catch::Contains(b.expect));
    CHECK_FALSE(fs::exists(out));
  }
  // One parameter on two axes, by index and by id: refused (before, the later axis overwrote the
  // other in every run, and the folders named values never run).
  {
    const fs::path out = fresh_dir("bad_twice");
    auto r = pipeline("sweep " + file + " --device cpu --set run.steps=10 --grid step.0.D=1,2 --grid step.brownian.integrate.D=3,4 --out " +
                      out.string());
    INFO(r.out);
    CHECK(r.code == 2);
    CHECK_THAT(r.out, Catch::Contains("sets the same parameter as --grid step.0.D=1,2 (step.brownian.integrate.D)"));
    CHECK_FALSE(fs::exists(out));
    auto brackets = pipeline("sweep " + file + " --device cpu --set run.steps=10 --grid step.0.D=1,2 --grid 'step[0].D=3,4' --out " +
                             out.string());
    CHECK(brackets.code == 2);
    CHECK_THAT(brackets.out, Catch::Contains("sets the same parameter as --grid step.0.D=1,2"));
    CHECK_FALSE(fs::exists(out));
  }
  // --replicas and a grid over the seed contradict each other.
  const fs::path out = fresh_dir("bad_seed");
  auto r = pipeline("sweep " + file + " --device cpu --replicas 2 --grid run.seed=1,2 --out " + out.string());
  CHECK(r.code == 2);
  CHECK_THAT(r.out, Catch::Contains("--replicas sets run.seed"));
  CHECK_FALSE(fs::exists(out));
}

TEST_CASE("sweep: a run that fails does not stop the others; its row says why; the sweep exits 1", "[sweep]") {
  // Valid for the loader and the dry run; the second value fails when the run makes its output
  // folder (a file named `blocker` is in the way).
  const fs::path out = fresh_dir("failing");
  fs::create_directories(out);
  std::ofstream(out / "blocker") << "in the way\n";
  auto r = pipeline("sweep " + repo_file("pipelines/brownian.yaml").string() +
                    " --device cpu --set run.steps=20 --set system.N=50 --grid 'step.observe.h5md.file=a.h5,../blocker/b.h5'"
                    " --grid run.seed=1,2 --force --out " + out.string());  // (--force: the folder holds the test's file)
  INFO(r.out);
  CHECK(r.code == 1);
  const auto rows = read_index(out / "index.csv");
  REQUIRE(rows.size() == 4);
  for (auto& row : rows) {
    INFO("row " << row.at("folder"));
    if (row.at("step.observe.h5md.file") == "a.h5") {
      CHECK(row.at("status") == "done");
      CHECK(fs::exists(out / row.at("folder") / "a.h5"));
    } else {
      CHECK(row.at("status") == "failed");
      CHECK(row.at("exit_code") == "2");
      CHECK_THAT(row.at("message"), Catch::Contains("cannot create the output folder"));
    }
  }
  CHECK_THAT(r.out, Catch::Contains("2 runs failed"));
  fs::remove_all(out);
  // A run whose own folder cannot be made (a file in its place) fails alone; before, the sweep
  // stopped there with a filesystem exception.
  const fs::path blocked = fresh_dir("blocked");
  fs::create_directories(blocked);
  std::ofstream(blocked / "seed=1") << "in the way\n";
  auto b = pipeline("sweep " + repo_file("pipelines/brownian.yaml").string() +
                    " --device cpu --set run.steps=20 --set system.N=50 --grid run.seed=1,2,3 --force --out " + blocked.string());
  INFO(b.out);
  CHECK(b.code == 1);
  for (auto& row : read_index(blocked / "index.csv")) {
    INFO("row " << row.at("folder"));
    CHECK(row.at("status") == (row.at("folder") == "seed=1" ? "failed" : "done"));
    if (row.at("folder") == "seed=1") CHECK_THAT(row.at("message"), Catch::Contains("cannot create its folder"));
  }
  fs::remove_all(blocked);
  // --gpus is for CUDA: refused with the CPU, before anything is written.
  const fs::path cpu = fresh_dir("gpus_on_cpu");
  auto g = pipeline("sweep " + repo_file("pipelines/brownian.yaml").string() + " --device cpu --gpus 0,1 --grid run.seed=1,2 --out " +
                    cpu.string());
  CHECK(g.code == 2);
  CHECK_THAT(g.out, Catch::Contains("--gpus is for CUDA"));
  CHECK_FALSE(fs::exists(cpu));
}

TEST_CASE("sweep: its folder: not another's files, not two sweeps at once, extended by grid values or replicas, told what differs",
          "[sweep]") {
  const std::string file = repo_file("pipelines/brownian.yaml").string();
  const std::string base = "sweep " + file + " --device cpu --set run.steps=20 --set system.N=50 --set step.observe.progress.every=1000";
  // A folder that is not a sweep's: refused, nothing in it touched (before: taken over, its index.csv replaced).
  const fs::path mine = fresh_dir("mine");
  fs::create_directories(mine);
  std::ofstream(mine / "index.csv") << "precious\n";
  auto taken = pipeline(base + " --grid run.seed=1,2 --out " + mine.string());
  INFO(taken.out);
  CHECK(taken.code == 2);
  CHECK_THAT(taken.out, Catch::Contains("is not a sweep's folder (it holds index.csv"));
  CHECK(file_text(mine / "index.csv") == "precious\n");
  fs::remove_all(mine);

  const fs::path out = fresh_dir("extend");
  auto first = require_success(pipeline(base + " --grid 'run.seed=1, 2' --out " + out.string()));  // (the space is trimmed)
  CHECK(fs::is_directory(out / "seed=2"));
  // The same command again: nothing to run, and it says so.
  CHECK_THAT(require_success(pipeline(base + " --grid run.seed=1,2 --out " + out.string())).out,
             Catch::Contains("nothing to run: all 2 runs were done before"));
  // A sweep.txt written before it recorded the device is the same sweep on today's device.
  {
    std::string recorded = file_text(out / "sweep.txt");
    const std::size_t device = recorded.find("device: ");
    REQUIRE(device != std::string::npos);
    recorded.erase(device, recorded.find('\n', device) - device + 1);
    std::ofstream(out / "sweep.txt") << recorded;
    CHECK_THAT(require_success(pipeline(base + " --grid run.seed=1,2 --out " + out.string())).out,
               Catch::Contains("nothing to run"));
  }
  // Values added to the axis: the sweep goes on in its folder; only the new run runs.
  auto more = require_success(pipeline(base + " --grid run.seed=1,2,3 --out " + out.string()));
  CHECK_THAT(more.out, Catch::Contains("extends the sweep in " + out.string() + " with run.seed=3") &&
                           Catch::Contains("1 to run, 2 done before"));
  CHECK(read_index(out / "index.csv").size() == 3);
  // Anything else: refused, saying what differs.
  auto other = pipeline(base + " --set run.dt=0.02 --grid run.seed=1,2,3 --out " + out.string());
  INFO(other.out);
  CHECK(other.code == 2);
  CHECK_THAT(other.out, Catch::Contains("holds another sweep") && Catch::Contains("now:  set: run.dt=0.02"));
  auto fewer = pipeline(base + " --grid run.seed=1,3 --out " + out.string());
  CHECK(fewer.code == 2);
  CHECK_THAT(fewer.out, Catch::Contains("was:  grid: run.seed=1,2,3") && Catch::Contains("now:  grid: run.seed=1,3"));
  // More replicas (from two): the sweep goes on with the new seeds; fewer, or more from one
  // (folders named without a seed), are other sweeps.
  const fs::path seeds = fresh_dir("replicas");
  const std::string d_axis = base + " --grid step.brownian.integrate.D=1 --out " + seeds.string();
  require_success(pipeline(d_axis + " --replicas 2"));
  auto three = require_success(pipeline(d_axis + " --replicas 3"));
  CHECK_THAT(three.out, Catch::Contains("extends the sweep in " + seeds.string() + " with replicas 2 -> 3 (seeds + 2 .. 2)") &&
                            Catch::Contains("1 to run, 2 done before"));
  CHECK(read_index(seeds / "index.csv").size() == 3);
  CHECK(fs::is_directory(seeds / "D=1_seed=44"));  // brownian.yaml: seed 42
  auto two = pipeline(d_axis + " --replicas 2");
  CHECK(two.code == 2);
  CHECK_THAT(two.out, Catch::Contains("was:  replicas: 3") && Catch::Contains("now:  replicas: 2"));
  fs::remove_all(seeds);
  require_success(pipeline(d_axis + " --replicas 1"));
  auto from_one = pipeline(d_axis + " --replicas 2");
  INFO(from_one.out);
  CHECK(from_one.code == 2);
  CHECK_THAT(from_one.out, Catch::Contains("one replica each, in folders named without a seed"));
  fs::remove_all(seeds);
  // The same --grid arguments in another order: another sweep (other folder names), and it says how
  // (before: "holds another sweep" with nothing under it).
  const fs::path two_axes = fresh_dir("two_axes");
  require_success(pipeline(base + " --grid run.seed=1,2 --grid step.brownian.integrate.D=1,2 --out " + two_axes.string()));
  auto reordered = pipeline(base + " --grid step.brownian.integrate.D=1,2 --grid run.seed=1,2 --out " + two_axes.string());
  INFO(reordered.out);
  CHECK(reordered.code == 2);
  CHECK_THAT(reordered.out, Catch::Contains("(in this order)"));
  fs::remove_all(two_axes);
  // A second sweep while one runs there (the lock file held by another process): refused.
  const fs::path lock = out / ".sweep.lock";
  const std::string hold = "exec 9<>" + lock.string() + "; flock -n 9 && echo 4242 >&9 && sleep 3";
  const pid_t holder = [&] {
    pid_t pid = 0;
    const char* argv[] = {"/bin/sh", "-c", hold.c_str(), nullptr};
    REQUIRE(posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char* const*>(argv), environ) == 0);
    return pid;
  }();
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  auto busy = pipeline(base + " --grid run.seed=1,2,3 --out " + out.string());
  INFO(busy.out);
  CHECK(busy.code == 2);
  CHECK_THAT(busy.out, Catch::Contains("is in use by another pipeline sweep (pid 4242)"));
  int status = 0;
  waitpid(holder, &status, 0);
  fs::remove_all(out);

  // Grid values: one number twice, a --set of the same parameter, a missing file.
  auto twice = pipeline(base + " --grid step.brownian.integrate.D=1,1.0 --out " + fresh_dir("twice").string());
  CHECK(twice.code == 2);
  CHECK_THAT(twice.out, Catch::Contains("the value '1.0' is given twice ('1' is the same value)"));
  auto zeros = pipeline(base + " --grid run.seed=0,-0 --out " + fresh_dir("zeros").string());
  CHECK(zeros.code == 2);
  CHECK_THAT(zeros.out, Catch::Contains("the value '-0' is given twice"));
  auto both = pipeline(base + " --set step.brownian.integrate.D=5 --grid step.brownian.integrate.D=1,2 --out " +
                       fresh_dir("both").string());
  CHECK(both.code == 2);
  CHECK_THAT(both.out, Catch::Contains("--set step.brownian.integrate.D=5 sets the same parameter"));
  auto missing = pipeline("sweep nothere.yaml --device cpu --grid run.seed=1,2 --out " + fresh_dir("missing").string());
  CHECK(missing.code == 2);
  CHECK_THAT(missing.out, Catch::Contains("cannot read pipeline file 'nothere.yaml'") && !Catch::Contains("with run.seed"));
}

TEST_CASE("sweep: --concurrent 2, in processes or threads, gives the same outputs as --concurrent 1",
          "[sweep][device]") {
  if (!device_available()) return;
  const fs::path out = fresh_dir("concurrent");
  auto r = require_success(pipeline(sweep_args(out) + " --concurrent 2"));
  CHECK_THAT(r.out, Catch::Contains("up to 2 at once"));
  require_same_sweep(out, reference_sweep());
  // Run again: every run is done, nothing runs, the index is unchanged but for nothing.
  const std::string index = file_text(out / "index.csv");
  auto again = pipeline(sweep_args(out) + " --concurrent 2");
  INFO(again.out);
  CHECK(again.code == 0);
  CHECK_THAT(again.out, Catch::Contains("0 to run, 8 done before"));
  CHECK(file_text(out / "index.csv") == index);
  // A different sweep in the same folder is refused.
  auto other = pipeline(sweep_args(out, {"run.dt=0.02"}));
  CHECK(other.code == 2);
  CHECK_THAT(other.out, Catch::Contains("holds another sweep"));
  fs::remove_all(out);
  // The same on threads of one process, whose runs write their files at once: the project's
  // HDF5 (Debian's) is built thread-safe, and without that the sweep refuses --in-process.
  CHECK(ff::hdf5_thread_safe());
  const fs::path threads = fresh_dir("in_process");
  auto t = require_success(pipeline(sweep_args(threads) + " --concurrent 2 --in-process"));
  CHECK_THAT(t.out, Catch::Contains("on threads of this process"));
  require_same_sweep(threads, reference_sweep());
  fs::remove_all(threads);
  // Each run's messages go to its own run.log, as a child process's would: here observe.progress's
  // lines (every 20 steps, no interval), which before went to the sweep's stderr, interleaved.
  const fs::path progress = fresh_dir("in_process_progress");
  auto p = require_success(pipeline(sweep_args(progress, {"step.observe.progress.every=20", "step.observe.progress.interval=0"}) +
                                    " --concurrent 2 --in-process"));
  CHECK_THAT(p.out, !Catch::Contains("step 40/60"));
  std::size_t logs = 0;
  for (auto& row : read_index(progress / "index.csv")) {
    const std::string log = file_text(progress / row.at("folder") / "run.log");
    INFO(row.at("folder") << "/run.log:\n" << log);
    CHECK_THAT(log, Catch::Contains("step 20/60") && Catch::Contains("step 40/60") && Catch::Contains("done: 60 steps"));
    // In order: the run's start line (run_pipeline's log), its progress (the stage), its end.
    CHECK(log.find("flipflow: ") < log.find("step 20/60"));
    CHECK(log.find("step 40/60") < log.find("done: 60 steps"));
    ++logs;
  }
  CHECK(logs == 8);
  fs::remove_all(progress);
}

TEST_CASE("sweep: killed (SIGKILL), stopped (SIGTERM) or Ctrl-C'd mid-way and run again, it finishes with the same outputs",
          "[sweep][kill]") {
  if (!device_available()) return;
  // Ctrl-C: SIGINT to the process group, so the runs get it from the terminal and SIGTERM from the
  // sweep. Before: the run took the second as "stop at once", exited 143 without a checkpoint, and
  // the sweep marked it failed.
  const int sig = GENERATE(SIGKILL, SIGTERM, -SIGINT);  // -SIGINT: Ctrl-C
  const bool ctrl_c = sig == -SIGINT;
  INFO("signal " << sig);
  const fs::path& ref = longer_reference_sweep();
  const fs::path out = fresh_dir("kill"), log = fresh_dir("kill_log");
  fs::create_directories(log);
  const pid_t pid = spawn(sweep_args(out, kLonger) + " --threads 1", log / "log");
  // Wait until a run has written its first checkpoint, then signal the sweep itself. SIGKILL:
  // its running run gets SIGTERM from the kernel, checkpoints and stops. SIGTERM: the sweep
  // passes it on, waits for the run to checkpoint, marks it interrupted and exits 3.
  bool checkpointed = false;
  for (int k = 0; k < 24000 && !checkpointed; ++k) {
    std::error_code ec;
    for (auto& e : fs::recursive_directory_iterator(out, ec))
      if (e.path().filename().string().rfind("checkpoint-", 0) == 0) checkpointed = true;
    int status;
    if (waitpid(pid, &status, WNOHANG) == pid) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (ctrl_c) ::kill(-pid, SIGINT);
  else ::kill(pid, sig);
  int status = 0;
  waitpid(pid, &status, 0);
  INFO(file_text(log / "log"));
  REQUIRE(checkpointed);
  if (sig != SIGKILL) {
    REQUIRE(WIFEXITED(status));
    CHECK(WEXITSTATUS(status) == 3);
    CHECK_THAT(file_text(log / "log"), Catch::Contains("run the same command again to continue"));
  } else {
    // Give the orphaned run time to write its checkpoint and exit.
    std::this_thread::sleep_for(std::chrono::seconds(2));
  }
  std::size_t unfinished = 0, interrupted = 0;
  for (auto& row : read_index(out / "index.csv")) {
    unfinished += row.at("status") != "done";
    interrupted += row.at("status") == "interrupted";
  }
  CHECK(unfinished > 0);
  // SIGTERM stops every run under way: one at a time on the CPU, one a GPU on CUDA (the default
  // --concurrent 1 on each GPU), so two on a machine of two GPUs.
  const std::size_t at_once = device() == "cuda" ? std::size_t(std::max(1, ff::cuda_device_count())) : 1;
  if (sig != SIGKILL) {
    CHECK_THAT(file_text(log / "log"), !Catch::Contains("FAILED"));
    CHECK(interrupted >= 1);
    CHECK(interrupted <= at_once);
  }
  require_success(pipeline(sweep_args(out, kLonger)));
  std::size_t resumed = 0;
  for (auto& row : read_index(out / "index.csv")) {
    CHECK(row.at("status") == "done");
    resumed += row.at("message") == "resumed from a checkpoint";
  }
  CHECK(resumed >= 1);
  require_same_sweep(out, ref);
  fs::remove_all(out);
  fs::remove_all(log);
}
