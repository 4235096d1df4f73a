// Simulation's output files: the names the stages write (checked at validate) and the folders
// made and probed before the first step. Apart from simulation.cpp, which builds and runs the step.
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "core/base/error.h"
#include "core/run/checkpoint.h"
#include "core/run/simulation.h"

namespace fs = std::filesystem;

namespace ff {

void Simulation::check_output_names() const {
  // Two stages writing one file would replace each other's output (or rename it away).
  std::vector<std::pair<fs::path, std::size_t>> seen;  // (file, the step writing it)
  for (std::size_t i = 0; i < slots_.size(); ++i)
    for (auto& o : slots_[i].stage->outputs()) {
      const fs::path p = fs::path(o).lexically_normal();
      const std::string name = p.filename().string();
      if (o.empty() || name.empty() || name == "." || name == "..")
        throw InputError(spec_.step[i].where.str() + ": step '" + spec_.step[i].id + "' writes to '" + o +
                         "', which is not a file name: give it a file name such as 'out.h5'");
      for (auto& [other, j] : seen)
        if (other == p)
          throw InputError(spec_.step[i].where.str() + ": step '" + spec_.step[i].id + "' writes '" + o +
                           "', which step '" + spec_.step[j].id + "' (" + spec_.step[j].where.str() +
                           ") writes too: give one of them another file name");
      seen.push_back({p, i});
      // Allowed (a scratch disk), but --out does not move it, and every run of a sweep would
      // write the one file.
      const bool outside = p.is_absolute() || (!p.empty() && *p.begin() == "..");
      if (outside)
        std::fprintf(options_.messages,
                     "flipflow: warning: %s: step '%s' writes '%s', outside the output folder: --out does not move "
                     "it, and runs that share the pipeline (a sweep's) would write the same file\n",
                     spec_.step[i].where.str().c_str(), spec_.step[i].id.c_str(), o.c_str());
    }
}

void Simulation::prepare_outputs() {
  std::vector<std::string> outputs;
  for (auto& s : slots_)
    for (auto& o : s.stage->outputs()) outputs.push_back(o);
  if (outputs.empty()) return;
  if (options_.out_dir.empty()) throw InputError("this pipeline writes files but no output directory was given (--out)");
  for (auto& o : outputs) {
    const fs::path p = fs::path(options_.out_dir) / o;
    if (options_.force || options_.resume) continue;
    if (fs::exists(p))
      throw InputError("output '" + p.string() + "' exists; use --force to overwrite it or --out to write elsewhere");
    // What an unfinished run kept (its outputs are written as NAME.partial until they are complete).
    if (fs::exists(p.string() + ".partial"))
      throw InputError("output '" + p.string() + ".partial' exists, kept by a run that did not finish; use " +
                       (checkpoint_files(options_.out_dir).empty() ? std::string()
                                                                   : "--resume to continue that run (from its checkpoint), ") +
                       "--force to overwrite it, or --out to write elsewhere");
  }
  std::error_code ec;
  fs::create_directories(options_.out_dir, ec);
  if (ec) throw InputError("cannot create output directory '" + options_.out_dir + "': " + ec.message());
  // Each output's folder made and written to now, not found unwritable after the run (observe.gr
  // and observe.clusters write theirs only at the end).
  std::set<fs::path> folders;
  for (auto& o : outputs) folders.insert((fs::path(options_.out_dir) / o).parent_path());
  for (auto& f : folders) {
    fs::create_directories(f, ec);
    if (ec) throw InputError("cannot create the output folder '" + f.string() + "': " + ec.message());
    const fs::path probe = f / (".flipflow-write-test-" + std::to_string(::getpid()));
    std::FILE* w = std::fopen(probe.c_str(), "w");
    const int err = errno;
    if (!w) throw InputError("cannot write in the output folder '" + f.string() + "': " + std::strerror(err));
    std::fclose(w);
    fs::remove(probe, ec);
  }
}

}  // namespace ff
