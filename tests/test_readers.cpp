// Our files opened by the readers users have (issue 19, item 5): Debian's MDAnalysis (2.4) reads
// observe.h5md's `layout: mdanalysis` files of a 2-D ABP run and a 3-D hard-sphere run, frame
// for frame equal to the plain layout's numbers, also after a --resume; it refuses the plain
// layout of a 2-D run (why the option exists); the plain layout stays as it was. tools/convert
// turns both layouts into GSD that gsd.hoomd reads back with the same positions (box-centred),
// images, types, box and orientations. The checks themselves are tests/support/check_readers.py.
// Skips visibly where /usr/bin/python3 lacks h5py, MDAnalysis or gsd (Debian: python3-h5py,
// python3-mdanalysis, python3-gsd; tools/setup installs them).
#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <unistd.h>

#include "support/cli.h"

namespace fs = std::filesystem;

namespace {
using ff::test::pipeline_exe;
using ff::test::repo_file;
using ff::test::require_success;

ff::test::CommandResult sh(const std::string& cmd, const fs::path& dir) {
  return ff::test::run_command(cmd, dir / "cmd.log");
}

bool python_has(const std::string& modules) {
  return std::system(("/usr/bin/python3 -W ignore -c 'import " + modules + "' >/dev/null 2>&1").c_str()) == 0;
}

struct Dir {
  fs::path path;
  explicit Dir(const std::string& name)
      : path(fs::temp_directory_path() / ("ff_readers_" + name + "_" + std::to_string(::getpid()))) {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~Dir() { fs::remove_all(path); }
};

std::string check(const std::string& args) {
  return "/usr/bin/python3 -W ignore " + repo_file("tests/support/check_readers.py").string() + " " + args;
}

// Runs the check and requires its "ok" line.
void require_ok(const std::string& args, const fs::path& dir) {
  auto r = require_success(sh(check(args), dir));
  CHECK_THAT(r.out, Catch::Contains("ok "));
}

void require_run(const std::string& args, const fs::path& dir) {
  require_success(sh(pipeline_exe() + " run " + args, dir));
}
}  // namespace

TEST_CASE("MDAnalysis reads observe.h5md's layout: mdanalysis (2-D ABP, 3-D hard spheres, resumed)", "[readers]") {
  if (!python_has("h5py, numpy, MDAnalysis")) {
    WARN("SKIPPED (no h5py/numpy/MDAnalysis in /usr/bin/python3; Debian: python3-mdanalysis): the MDAnalysis layout");
    return;
  }
  Dir d("mda");
  const fs::path& dir = d.path;
  const std::string md = " --set step.observe.h5md.layout=mdanalysis";

  SECTION("2-D ABP with orientations") {
    const std::string abp = repo_file("pipelines/abp.yaml").string() +
                            " --device cpu --set system.N=300 --set run.steps=300 --set step.observe.progress.every=1000";
    require_run(abp + " --out " + (dir / "plain").string(), dir);
    require_run(abp + md + " --out " + (dir / "md").string(), dir);
    require_ok("mdanalysis " + (dir / "md/abp.h5").string() + " " + (dir / "plain/abp.h5").string(), dir);
    require_ok("refused " + (dir / "plain/abp.h5").string(), dir);
    require_ok("plain " + (dir / "plain/abp.h5").string(), dir);

    // Continued from a checkpoint: the same file as one run (the box rows and the NaN-padded
    // observables are continued too), and MDAnalysis still reads it.
    const std::string ck = md + " --set 'run.checkpoint={every: 100}'";
    require_run(abp + ck + " --out " + (dir / "one").string(), dir);
    require_run(abp + ck + " --set run.steps=200 --out " + (dir / "two").string(), dir);
    require_run(abp + ck + " --out " + (dir / "two").string() + " --resume", dir);
    require_ok("same " + (dir / "one/abp.h5").string() + " " + (dir / "two/abp.h5").string(), dir);
    require_ok("mdanalysis " + (dir / "two/abp.h5").string() + " " + (dir / "plain/abp.h5").string(), dir);
  }
  SECTION("3-D hard spheres") {
    const std::string hs = repo_file("pipelines/hard-spheres.yaml").string() +
                           " --device cpu --set system.N=200 --set run.steps=300 --set step.observe.h5md.every=100";
    require_run(hs + " --out " + (dir / "plain").string(), dir);
    require_run(hs + md + " --out " + (dir / "md").string(), dir);
    require_ok("mdanalysis " + (dir / "md/trajectory.h5").string() + " " + (dir / "plain/trajectory.h5").string(), dir);
    require_ok("plain " + (dir / "plain/trajectory.h5").string(), dir);
  }
}

TEST_CASE("tools/convert writes GSD that gsd.hoomd reads back (2-D with orientations, 3-D, both layouts)",
          "[readers]") {
  if (!python_has("h5py, numpy, gsd.hoomd")) {
    WARN("SKIPPED (no h5py/numpy/gsd in /usr/bin/python3; Debian: python3-gsd): tools/convert");
    return;
  }
  Dir d("gsd");
  const fs::path& dir = d.path;
  const std::string convert = "/usr/bin/python3 " + repo_file("tools/convert").string();
  const std::string abp = repo_file("pipelines/abp.yaml").string() +
                          " --device cpu --set system.N=300 --set run.steps=300 --set step.observe.progress.every=1000";
  const std::string hs = repo_file("pipelines/hard-spheres.yaml").string() +
                         " --device cpu --set system.N=200 --set run.steps=300 --set step.observe.h5md.every=100";
  require_run(abp + " --out " + (dir / "abp").string(), dir);
  require_run(abp + " --set step.observe.h5md.layout=mdanalysis --out " + (dir / "abp_md").string(), dir);
  require_run(hs + " --out " + (dir / "hs").string(), dir);
  for (const std::string h5 : {"abp/abp.h5", "abp_md/abp.h5", "hs/trajectory.h5"}) {
    const fs::path in = dir / h5, out = fs::path(in).replace_extension(".gsd");
    auto r = require_success(sh(convert + " " + in.string(), dir));  // default output: FILE.gsd beside it
    CHECK_THAT(r.out, Catch::Contains("4 frames"));
    REQUIRE(fs::exists(out));
    require_ok("gsd " + out.string() + " " + in.string(), dir);
  }
  // A coordinate just below L (float64) is L/2 in GSD's float32 after centring: HOOMD's box is
  // [-L/2, L/2), so convert wraps it (before: it wrote L/2, outside the box).
  {
    const fs::path edge = dir / "abp" / "edge.h5";
    fs::copy_file(dir / "abp/abp.h5", edge, fs::copy_options::overwrite_existing);
    require_success(sh("/usr/bin/python3 -c \"import h5py, numpy as np, sys; f = h5py.File(sys.argv[1], 'r+'); "
                       "L = f['particles/all/box/edges'][0]; v = f['particles/all/position/value']; "
                       "x = v[-1]; x[0, 0] = np.nextafter(L, 0); x[1, 1] = np.nextafter(L, 0); v[-1] = x\" " +
                           edge.string(),
                       dir));
    require_success(sh(convert + " " + edge.string(), dir));
    require_ok("gsd " + (dir / "abp" / "edge.gsd").string() + " " + edge.string(), dir);
  }
  // Boids: σ = 0.5 (readers would take a missing diameter as 1) and headings in boids.heading.
  require_run(repo_file("pipelines/boids.yaml").string() +
                  " --device cpu --set system.N=300 --set run.steps=200 --out " + (dir / "boids").string(),
              dir);
  auto b = require_success(sh(convert + " " + (dir / "boids/boids.h5").string(), dir));
  CHECK_THAT(b.out, Catch::Contains("orientations from /particles/all/boids.heading") &&
                        Catch::Contains("diameters from /parameters/effective_pipeline"));
  require_ok("gsd " + (dir / "boids/boids.gsd").string() + " " + (dir / "boids/boids.h5").string(), dir);

  SECTION("bad input exits 2 naming the problem") {
    auto r = sh(convert + " " + (dir / "nothing.h5").string(), dir);
    CHECK(r.code == 2);
    CHECK_THAT(r.out, Catch::Contains("no such file"));
    require_run(repo_file("pipelines/abp.yaml").string() +
                    " --device cpu --set system.N=100 --set run.steps=10 --set step.observe.h5md.fields=[orientation]"
                    " --out " + (dir / "nopos").string(),
                dir);
    r = sh(convert + " " + (dir / "nopos/abp.h5").string(), dir);
    CHECK(r.code == 2);
    CHECK_THAT(r.out, Catch::Contains("/particles/all/position/value"));
  }
}
