// tools/render end to end: `pipeline run` writes a small H5MD file (ABP, with orientations), and
// /usr/bin/python3 tools/render draws its last frame and plots an observable to PNG files; bad
// input exits 2 with a message naming the file and the missing path. Skips visibly where
// /usr/bin/python3 lacks numpy, h5py or matplotlib (a GPU node running a bundle).
#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "support/cli.h"

namespace fs = std::filesystem;

namespace {
using ff::test::pipeline_exe;
using ff::test::repo_file;
using ff::test::require_success;

// `cmd` through the shell, output captured in `dir`/cmd.log.
ff::test::CommandResult sh(const std::string& cmd, const fs::path& dir) { return ff::test::run_command(cmd, dir / "cmd.log"); }

// Whether /usr/bin/python3 can plot (and import `also`, for --voronoi); says visibly that the
// test skips when it cannot.
bool have_plotting(const std::string& also = "") {
  const std::string modules = "h5py, numpy, matplotlib" + (also.empty() ? "" : ", " + also);
  const bool ok = std::system(("/usr/bin/python3 -c 'import " + modules + "' >/dev/null 2>&1").c_str()) == 0;
  if (!ok) WARN("SKIPPED (no " + modules + " in /usr/bin/python3): tools/render");
  return ok;
}

// An empty scratch folder for one test case, named after it and this process.
fs::path fresh_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / (name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string render_command() { return "/usr/bin/python3 " + repo_file("tools/render").string(); }

bool is_png(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  char sig[8] = {};
  in.read(sig, 8);
  static const unsigned char want[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  return in.gcount() == 8 && std::equal(sig, sig + 8, reinterpret_cast<const char*>(want));
}
}  // namespace

TEST_CASE("tools/render draws an H5MD frame and an observable to PNG; bad input exits 2", "[cli][render]") {
  if (!have_plotting()) return;
  const fs::path dir = fresh_dir("ff_render");
  const std::string render = render_command();

  require_success(sh(pipeline_exe() + " run " + repo_file("pipelines/abp.yaml").string() +
                         " --device cpu --set run.steps=200 --set system.N=300 --out " + (dir / "run").string(),
                     dir));
  const fs::path h5 = dir / "run" / "abp.h5";
  REQUIRE(fs::exists(h5));

  SECTION("last frame, coloured by orientation") {
    auto r = sh(render + " " + h5.string() + " --out " + (dir / "frame.png").string() + " --dpi 40", dir);
    INFO(r.out);
    CHECK(r.code == 0);
    CHECK_THAT(r.out, Catch::Contains("colour by orientation"));
    CHECK(is_png(dir / "frame.png"));
  }
  SECTION("first frame by species; an observable") {
    auto r = sh(render + " " + h5.string() + " --frame 0 --color-by species --out " + (dir / "f0.png").string() +
                    " --dpi 40",
                dir);
    INFO(r.out);
    CHECK(r.code == 0);
    CHECK(is_png(dir / "f0.png"));
    auto o = sh(render + " " + h5.string() + " --plot-observable observe.msd/msd --out " + (dir / "msd.png").string() +
                    " --dpi 40",
                dir);
    INFO(o.out);
    CHECK(o.code == 0);
    CHECK(is_png(dir / "msd.png"));
  }
  SECTION("errors name the file and the missing path") {
    auto f = sh(render + " " + h5.string() + " --frame 99 --out " + (dir / "x.png").string(), dir);
    CHECK(f.code == 2);
    CHECK_THAT(f.out, Catch::Contains("abp.h5") && Catch::Contains("out of range"));
    auto o = sh(render + " " + h5.string() + " --plot-observable no_such --out " + (dir / "x.png").string(), dir);
    CHECK(o.code == 2);
    CHECK_THAT(o.out, Catch::Contains("/observables/no_such/value") && Catch::Contains("observe.msd/msd"));
    auto msd = sh(render + " " + h5.string() + " --plot-observable msd --out " + (dir / "x.png").string(), dir);
    CHECK(msd.code == 2);
    CHECK_THAT(msd.out, Catch::Contains("did you mean 'observe.msd/msd'?"));
    auto typo = sh(render + " " + h5.string() + " --color-by orientaton --out " + (dir / "x.png").string(), dir);
    CHECK(typo.code == 2);
    CHECK_THAT(typo.out, Catch::Contains("did you mean 'orientation'?"));
    // One line, no Python traceback, for a colour map or output format matplotlib lacks.
    auto cmap = sh(render + " " + h5.string() + " --cmap virdis --out " + (dir / "x.png").string(), dir);
    CHECK(cmap.code == 2);
    CHECK_THAT(cmap.out, Catch::Contains("--cmap virdis") && Catch::Contains("did you mean viridis") &&
                             !Catch::Contains("Traceback"));
    auto txt = sh(render + " " + h5.string() + " --out " + (dir / "x.txt").string(), dir);
    CHECK(txt.code == 2);
    CHECK_THAT(txt.out, Catch::Contains("cannot write .txt files") && !Catch::Contains("Traceback"));
    CHECK_FALSE(fs::exists(dir / "x.txt"));
    auto m = sh(render + " " + (dir / "missing.h5").string(), dir);
    CHECK(m.code == 2);
    CHECK_THAT(m.out, Catch::Contains("missing.h5"));
    // A file without positions.
    require_success(sh("/usr/bin/python3 -c \"import h5py; h5py.File('" + (dir / "empty.h5").string() +
                           "','w').create_group('particles/all')\"",
                       dir));
    auto e = sh(render + " " + (dir / "empty.h5").string(), dir);
    CHECK(e.code == 2);
    CHECK_THAT(e.out, Catch::Contains("empty.h5") && Catch::Contains("/particles/all/position/value"));
    CHECK_FALSE(fs::exists(dir / "x.png"));
  }
  fs::remove_all(dir);
}

TEST_CASE("tools/render plots a 3D run's aggregates on a log time axis and draws 3D frames", "[cli][render]") {
  if (!have_plotting()) return;
  const fs::path dir = fresh_dir("ff_render3d");
  const std::string render = render_command();

  // Tran's aggregation (pipelines/tran-homo-phi0.20-short.yaml), cut to 300 spheres and 500 steps.
  require_success(sh(pipeline_exe() + " run " + repo_file("pipelines/tran-homo-phi0.20-short.yaml").string() +
                         " --device cpu --set run.steps=500 --set system.N=300 --out " + (dir / "run").string(),
                     dir));
  const fs::path h5 = dir / "run" / "tran-homo-phi0.20-short.h5", csv = dir / "run" / "clusters.csv",
                 frames = dir / "run" / "tran-homo-phi0.20-short-frames.h5";
  // The curves' file has no frames: the message points at the frames' file beside it.
  auto curves = sh(render + " " + h5.string() + " --out " + (dir / "x.png").string(), dir);
  CHECK(curves.code == 2);
  CHECK_THAT(curves.out, Catch::Contains("the positions of this run are in") && Catch::Contains("-frames.h5"));

  SECTION("N_agg(t) from the H5MD file and clusters.csv on one plot, as Tran's Fig. 3") {
    auto r = sh(render + " " + h5.string() + " " + csv.string() +
                    " --plot-observable observe.clusters/aggregates --log --out " + (dir / "fig3.png").string() +
                    " --dpi 40",
                dir);
    INFO(r.out);
    CHECK(r.code == 0);
    CHECK_THAT(r.out, Catch::Contains("from 2 file(s)") && Catch::Contains("log time axis"));
    CHECK(is_png(dir / "fig3.png"));
    auto m = sh(render + " " + csv.string() + " --plot-observable observe.clusters/nosuch --out " +
                    (dir / "x.png").string(),
                dir);
    CHECK(m.code == 2);
    CHECK_THAT(m.out, Catch::Contains("clusters.csv: no column 'nosuch'") && Catch::Contains("aggregates"));
  }
  SECTION("3D frames: the projection along z, or a slab") {
    auto p = sh(render + " " + frames.string() + " --out " + (dir / "p.png").string() + " --dpi 40", dir);
    INFO(p.out);
    CHECK(p.code == 0);
    // Without --color-by, coloured by depth: one colour alone makes the projection a solid blob.
    CHECK_THAT(p.out, Catch::Contains("colour by depth") && Catch::Contains("projection along z: 300 spheres drawn"));
    CHECK(is_png(dir / "p.png"));
    auto d = sh(render + " " + frames.string() + " --slice 4 --color-by depth --out " + (dir / "x.png").string(), dir);
    CHECK(d.code == 2);
    CHECK_THAT(d.out, Catch::Contains("--color-by depth is for the projection of a 3D frame"));
    auto s = sh(render + " " + frames.string() + " --slice 4 --out " + (dir / "s.png").string() + " --dpi 40", dir);
    INFO(s.out);
    CHECK(s.code == 0);
    // Each sphere that cuts the mid-plane as its cross-section with it, not at its full diameter.
    CHECK_THAT(s.out, Catch::Contains("slice z ∈") && Catch::Contains("cross-sections with z =") &&
                          Catch::Contains("cross-sections drawn"));
    CHECK(is_png(dir / "s.png"));
    auto two = sh(render + " " + frames.string() + " " + h5.string() + " --out " + (dir / "x.png").string(), dir);
    CHECK(two.code == 2);
    CHECK_THAT(two.out, Catch::Contains("only for --plot-observable"));
  }
  fs::remove_all(dir);
}

TEST_CASE("tools/render's titles fit the figure and its quantities are labelled in words", "[cli][render]") {
  // They show only in the image: tests/support/check_render_labels.py calls fit_title,
  // quantity_label and curve_labels directly (a long title wrapped inside the figure, a short
  // one untouched, an unbreakable one shrunk; labels with units; files of one name told apart).
  if (!have_plotting()) return;
  const fs::path dir = fresh_dir("ff_render_labels");
  auto r = sh("/usr/bin/python3 " + repo_file("tests/support/check_render_labels.py").string() + " " +
                  repo_file("tools/render").string(),
              dir);
  INFO(r.out);
  CHECK(r.code == 0);
  CHECK_THAT(r.out, Catch::Contains("ok labels"));
  fs::remove_all(dir);
}

TEST_CASE("tools/render: a 3D run with orientations is drawn by depth, or by the orientations' azimuth", "[cli][render]") {
  if (!have_plotting()) return;
  const fs::path dir = fresh_dir("ff_render3dabp");
  const std::string render = render_command();
  std::ofstream(dir / "abp3d.yaml") << R"(system: {dimensions: 3, N: 200, packing_fraction: 0.2, init: random}
run: {steps: 20, dt: 0.01, seed: 3}
plugins: [abp]
step:
  - {stage: abp.integrate, v0: 1.0, Dr: 0.5, D: 0.01}
  - {stage: observe.h5md, every: 10, file: abp3d.h5, fields: [position, image, orientation]}
)";
  require_success(sh(pipeline_exe() + " run " + (dir / "abp3d.yaml").string() + " --device cpu --out " +
                         (dir / "run").string(),
                     dir));
  const fs::path h5 = dir / "run" / "abp3d.h5";
  // The default: depth, as for any projection (the azimuth alone would hide which sphere is in front).
  auto d = sh(render + " " + h5.string() + " --out " + (dir / "d.png").string() + " --dpi 40", dir);
  INFO(d.out);
  CHECK(d.code == 0);
  CHECK_THAT(d.out, Catch::Contains("colour by depth") && Catch::Contains("200 spheres drawn"));
  CHECK(is_png(dir / "d.png"));
  // Unit vectors of three components are coloured by their azimuth in the x-y plane.
  auto o = sh(render + " " + h5.string() + " --color-by orientation --out " + (dir / "o.png").string() + " --dpi 40", dir);
  INFO(o.out);
  CHECK(o.code == 0);
  CHECK_THAT(o.out, Catch::Contains("colour by orientation"));
  CHECK(is_png(dir / "o.png"));
  fs::remove_all(dir);
}

TEST_CASE("tools/render colours by a per-particle field (voronoi.area, voronoi.sides) and draws Voronoi cells",
          "[cli][render][voronoi]") {
  if (!have_plotting("scipy")) return;
  const fs::path dir = fresh_dir("ff_render_vor");
  const std::string render = render_command();
  // Frames at steps 0 and 1000: frame 0 is written before voronoi.geometry first runs (areas 0).
  require_success(sh(pipeline_exe() + " run " + repo_file("pipelines/voronoi-hard-disks.yaml").string() +
                         " --device cpu --set run.steps=1000 --set system.N=400 --out " + (dir / "run").string(),
                     dir));
  const fs::path h5 = dir / "run" / "trajectory.h5";

  auto a = sh(render + " " + h5.string() + " --voronoi --color-by voronoi.area --out " + (dir / "a.png").string() +
                  " --dpi 40",
              dir);
  INFO(a.out);
  CHECK(a.code == 0);
  CHECK_THAT(a.out, Catch::Contains("colour by voronoi.area") && Catch::Contains("Voronoi cells of 400 points"));
  CHECK_THAT(a.out, Catch::Contains("largest difference") && !Catch::Contains("warning"));
  CHECK(is_png(dir / "a.png"));
  auto z = sh(render + " " + h5.string() + " --frame 0 --voronoi --color-by voronoi.area --out " +
                  (dir / "z.png").string() + " --dpi 40",
              dir);
  INFO(z.out);
  // Frame 0 precedes the first step, so voronoi.area was not computed yet: observe.h5md writes it
  // as NaN, and render says so and which frame to draw instead (before: it drew cells coloured by
  // zeros, with a warning; files of that time still get it).
  CHECK(z.code == 2);
  CHECK_THAT(z.out, Catch::Contains("voronoi.area has no values at frame 0: it is NaN, not computed yet") &&
                        Catch::Contains("--frame 1"));
  CHECK_FALSE(fs::exists(dir / "z.png"));
  // Drawn clipped by walls the run did not have (voronoi.geometry's cells are periodic): the hint names the walls.
  auto w = sh(render + " " + h5.string() + " --walls y --voronoi --color-by voronoi.area --out " +
                  (dir / "w.png").string() + " --dpi 40",
              dir);
  INFO(w.out);
  CHECK(w.code == 0);
  CHECK_THAT(w.out, Catch::Contains("cells are not the Voronoi cells of the frame's positions") &&
                        Catch::Contains("the walls differ: the picture's cells are clipped by walls ⟂ y") &&
                        Catch::Contains("voronoi.geometry's cells are periodic"));
  auto s = sh(render + " " + h5.string() + " --color-by voronoi.sides --out " + (dir / "s.png").string() + " --dpi 40",
              dir);
  INFO(s.out);
  CHECK(s.code == 0);
  CHECK(is_png(dir / "s.png"));
  auto bad = sh(render + " " + h5.string() + " --color-by voronoi.nosuch --out " + (dir / "x.png").string(), dir);
  CHECK(bad.code == 2);
  CHECK_THAT(bad.out, Catch::Contains("/particles/all/voronoi.nosuch/value") && Catch::Contains("voronoi.area"));
  CHECK_FALSE(fs::exists(dir / "x.png"));
  fs::remove_all(dir);
}

TEST_CASE("tools/render takes σ and the walls from the run's --set overrides (/parameters/effective_pipeline)",
          "[cli][render][voronoi]") {
  if (!have_plotting("scipy")) return;
  const fs::path dir = fresh_dir("ff_render_set");
  const std::string render = render_command();

  SECTION("--set system.sigma=2: disks of diameter 2") {
    require_success(sh(pipeline_exe() + " run " + repo_file("pipelines/hard-disks.yaml").string() +
                           " --device cpu --set run.steps=100 --set system.N=100 --set system.sigma=2 --out " +
                           (dir / "run").string(),
                       dir));
    auto r = sh(render + " " + (dir / "run" / "trajectory.h5").string() + " --out " + (dir / "s.png").string() +
                    " --dpi 40",
                dir);
    INFO(r.out);
    CHECK(r.code == 0);
    CHECK_THAT(r.out, Catch::Contains("diameters from /parameters/effective_pipeline: 2,"));
    CHECK(is_png(dir / "s.png"));
  }
  SECTION("--set ...walls=x: the cells cut by walls at x = 0 and L_x") {
    require_success(sh(pipeline_exe() + " run " + repo_file("pipelines/hard-disks-slab-voronoi.yaml").string() +
                           " --device cpu --set run.steps=1000 --set system.N=300 --set step.overlap_correct.walls=x"
                           " --set step.voronoi.mirror_observer.walls=x --out " +
                           (dir / "run").string(),
                       dir));
    auto r = sh(render + " " + (dir / "run" / "trajectory.h5").string() + " --voronoi --color-by voronoi.area --out " +
                    (dir / "w.png").string() + " --dpi 40",
                dir);
    INFO(r.out);
    CHECK(r.code == 0);
    CHECK_THAT(r.out, Catch::Contains("walls ⟂ x") && Catch::Contains("largest difference"));
    CHECK(is_png(dir / "w.png"));
    // The walls on a frame drawn without --voronoi too.
    auto p = sh(render + " " + (dir / "run" / "trajectory.h5").string() + " --out " + (dir / "p.png").string() +
                    " --dpi 40",
                dir);
    INFO(p.out);
    CHECK(p.code == 0);
    CHECK_THAT(p.out, Catch::Contains("colour by species; walls ⟂ x"));
    CHECK(is_png(dir / "p.png"));
    // The default names of two pictures of one frame differ (hard-disks-slab.yaml suggests both).
    const std::string h5 = (dir / "run" / "trajectory.h5").string();
    require_success(sh(render + " " + h5 + " --color-by voronoi.sides --dpi 40", dir));
    require_success(sh(render + " " + h5 + " --voronoi --color-by voronoi.area --dpi 40", dir));
    CHECK(is_png(dir / "run" / "trajectory-step1000-voronoi.sides.png"));
    CHECK(is_png(dir / "run" / "trajectory-step1000-voronoi.area-cells.png"));
  }
  fs::remove_all(dir);
}

TEST_CASE("tools/render plots gr.csv's g(r) against r/σ; a CSV file without --plot-observable lists its columns",
          "[cli][render]") {
  if (!have_plotting()) return;
  const fs::path dir = fresh_dir("ff_render_gr");
  const std::string render = render_command();
  require_success(sh(pipeline_exe() + " run " + repo_file("pipelines/hard-disks.yaml").string() +
                         " --device cpu --set run.steps=300 --set system.N=200 --set step.observe.gr.from_step=100"
                         " --out " +
                         (dir / "run").string(),
                     dir));
  const fs::path csv = dir / "run" / "gr.csv";

  auto g = sh(render + " " + csv.string() + " --plot-observable g --out " + (dir / "g.png").string() + " --dpi 40",
              dir);
  INFO(g.out);
  CHECK(g.code == 0);
  CHECK_THAT(g.out, Catch::Contains("x: r / σ"));  // the axis as the figure labels it
  CHECK(is_png(dir / "g.png"));
  auto x = sh(render + " " + csv.string() + " --plot-observable g --x r_lo --out " + (dir / "lo.png").string() +
                  " --dpi 40",
              dir);
  INFO(x.out);
  CHECK(x.code == 0);
  CHECK_THAT(x.out, Catch::Contains("x: r_lo"));
  auto bad = sh(render + " " + csv.string() + " --plot-observable g --x nosuch --out " + (dir / "x.png").string(), dir);
  CHECK(bad.code == 2);
  CHECK_THAT(bad.out, Catch::Contains("--x nosuch: no such column") && Catch::Contains("r_lo, r_hi, r, g, pairs"));
  auto bare = sh(render + " " + csv.string() + " --out " + (dir / "x.png").string(), dir);
  CHECK(bare.code == 2);
  CHECK_THAT(bare.out, Catch::Contains("gr.csv: a CSV file") && Catch::Contains("--plot-observable") &&
                           Catch::Contains("r_lo, r_hi, r, g, pairs"));
  CHECK_FALSE(fs::exists(dir / "x.png"));
  fs::remove_all(dir);
}

TEST_CASE("tools/render colours cluster.label by cluster, monomers grey, without a tick per label", "[cli][render]") {
  if (!have_plotting()) return;
  const fs::path dir = fresh_dir("ff_render_label");
  const std::string render = render_command();
  require_success(sh(pipeline_exe() + " run " + repo_file("pipelines/clusters-demo.yaml").string() +
                         " --device cpu --set run.steps=500 --set system.N=300 --out " + (dir / "run").string(),
                     dir));

  auto r = sh(render + " " + (dir / "run" / "clusters-demo.h5").string() + " --color-by cluster.label --out " +
                  (dir / "c.png").string() + " --dpi 40",
              dir);
  INFO(r.out);
  CHECK(r.code == 0);
  CHECK_THAT(r.out, Catch::Contains("colour by cluster.label (") && Catch::Contains("monomers grey"));
  CHECK_THAT(r.out, !Catch::Contains("Locator"));
  CHECK(is_png(dir / "c.png"));
  fs::remove_all(dir);
}

TEST_CASE("tools/render draws cluster_sizes.csv as the cluster-size distribution, either layout", "[cli][render]") {
  if (!have_plotting()) return;
  const fs::path dir = fresh_dir("ff_render_sizes");
  const std::string render = render_command();
  // The cell-list observer in the long layout, the Delaunay one in the wide layout with K = 300 = N.
  require_success(sh(pipeline_exe() + " run " + repo_file("pipelines/clusters-demo.yaml").string() +
                         " --device cpu --set run.steps=500 --set system.N=300 --set step.clusters.sizes_layout=long"
                         " --set step.clusters_delaunay.sizes_layout=wide --set step.clusters_delaunay.size_columns=300"
                         " --set step.clusters_delaunay.every=100 --out " +
                         (dir / "run").string(),
                     dir));
  const fs::path long_csv = dir / "run" / "cluster_sizes.csv", wide_csv = dir / "run" / "cluster-sizes-delaunay.csv";
  auto r = sh(render + " " + long_csv.string() + " " + wide_csv.string() + " --from-step 100 --out " +
                  (dir / "d.png").string() + " --dpi 40",
              dir);
  INFO(r.out);
  CHECK(r.code == 0);
  CHECK_THAT(r.out, Catch::Contains("cluster-size distribution from 2 file(s)"));
  // Every particle takes part, so the sizes times their mean counts add up to N in both layouts
  // (no cluster of all 300 particles, which would fall in the wide file's n300plus column).
  CHECK_THAT(r.out, Catch::Contains("cluster_sizes.csv: ") && Catch::Contains("cluster-sizes-delaunay.csv: 5 calls (steps 100 to 500)"));
  std::size_t sums = 0;
  for (std::size_t at = r.out.find("Σ n⟨N_n⟩ = 300\n"); at != std::string::npos; at = r.out.find("Σ n⟨N_n⟩ = 300\n", at + 1))
    ++sums;
  CHECK(sums == 2);
  CHECK(is_png(dir / "d.png"));
  auto late = sh(render + " " + long_csv.string() + " --from-step 600 --out " + (dir / "x.png").string(), dir);
  CHECK(late.code == 2);
  CHECK_THAT(late.out, Catch::Contains("no call at step 600 or later (its calls: steps"));
  auto mixed = sh(render + " " + long_csv.string() + " " + (dir / "run" / "clusters.csv").string() + " --out " +
                      (dir / "x.png").string(),
                  dir);
  CHECK(mixed.code == 2);
  CHECK_THAT(mixed.out, Catch::Contains("draw cluster_sizes.csv files"));
  CHECK_FALSE(fs::exists(dir / "x.png"));
  fs::remove_all(dir);
}
