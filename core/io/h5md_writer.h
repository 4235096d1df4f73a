// A small H5MD 1.1 writer (https://www.nongnu.org/h5md/h5md.html). No HDF5 types here: the
// core links HDF5 privately, so stages and tools only see this class.
//
// Layout written:
//   /h5md                      attr version = int[2] {1, 1}
//     author                   attr name
//     creator                  attrs name = "flipflow", version
//   /particles/all/box         attrs dimension (int), boundary ("periodic" x dim); dataset edges [dim]
//   /particles/all/species     int32 [N], time-independent (attr names: the species names)
//   /particles/all/<element>   time-dependent: step int64 [frames], time double [frames],
//                              value [frames, N, components] ([frames, N] for one component)
//   /observables/<name>        time-dependent scalars {step, time, value double [frames]};
//                              a '/' in the name makes subgroups ("stage_id/metric")
//   /connectivity/<name>       time-dependent triangles: value int32 [frames, M, 3], rows past a
//                              frame's own M are -1; attr particles_group -> /particles/all
//   /parameters                dataset pipeline (the YAML text), attrs for the run settings,
//                              further text datasets (effective_pipeline, resolved, ...) and,
//                              for a run continued from a checkpoint, history/<k>: one group
//                              per continuation (attrs: step, checkpoint, changes, ...)
//
// Layout for 3-D-only readers (H5mdHeader::readers_layout, observe.h5md `layout: mdanalysis`):
// MDAnalysis refuses boxes whose dimension is not 3, reads the box only from a time-dependent
// box/edges/value of box matrices, and reads row k of every /observables/<name>/value for
// frame k. So box/edges is a time-dependent element {step, time, value [frames, 3, 3]} (the
// diagonal box matrix) with one row per frame of the first particle element; observables are
// flat (a '/' in a name becomes '.') and one that starts after the first frame (a stage
// metric) has NaN in the frames before, so its rows line up with the frames. A 2-D run is
// written as a 3-D one: box dimension 3, boundary {periodic, periodic, none}, a nominal
// Lz = 1 (so N / volume is the area density) and attr flipflow_dimension = 2; every
// per-particle element of 2 components (position, image, velocity, ...) gets a zero third
// component (attr flipflow_padded_from = 2 on its value dataset).
//
// Nothing half-written: the file is created as `<path>.partial` and flushed after every frame
// (flush()), so a killed run leaves a readable partial file; close(true) renames it to `path`,
// close(false) keeps the .partial and says so (on stderr, or where report_to says). A write that fails (a full disk)
// throws RunError naming the file; close() then extends the file by a hole to the space HDF5
// had claimed, so the frames flushed before stay readable.
//
// Not thread-safe: one thread at a time (observe.h5md hands its writer to one writer thread).
#pragma once
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/base/types.h"

namespace ff {

struct H5mdHeader {
  std::string author;          // /h5md/author name (empty: the login name)
  int dim = 2;
  double edges[3] = {0, 0, 0};
  bool readers_layout = false; // the 3-D-only readers' layout above
  std::string pipeline_text;   // /parameters/pipeline (omitted when empty)
  std::vector<std::pair<std::string, std::string>> run_attributes;  // /parameters attributes
  std::vector<std::pair<std::string, std::string>> texts;           // /parameters/<name> datasets
};

class H5mdWriter {
 public:
  // Creates `<path>.partial` (replacing a stale one) and writes /h5md, the box and /parameters.
  // RunError if the file cannot be created.
  H5mdWriter(std::string path, const H5mdHeader& header);
  // Continue the file of a run resumed from a checkpoint at `last_step`: opens `<path>.partial`
  // (a run that stopped early), else `path` (a finished run being extended), renamed to the
  // .partial; drops every frame after `last_step` in every element, observable and
  // connectivity (frames written after the checkpoint, before a crash), so appending continues
  // the file exactly as an uninterrupted run would have written it; records `history` as
  // /parameters/history/<k> (attributes). Null when neither file exists. RunError when the file
  // cannot be opened or is not one this writer made.
  static std::unique_ptr<H5mdWriter> reopen(std::string path, std::int64_t last_step,
                                            const std::vector<std::pair<std::string, std::string>>& history);
  // A writer destroyed without close() closes as not completed (keeps the .partial).
  ~H5mdWriter();
  H5mdWriter(const H5mdWriter&) = delete;
  H5mdWriter& operator=(const H5mdWriter&) = delete;

  const std::string& path() const { return path_; }
  std::string partial_path() const { return path_ + ".partial"; }
  bool is_open() const { return impl_ != nullptr; }
  // Where the writer's messages to the user go (what a failed run kept): stderr unless told
  // (observe.h5md passes its run's RunInfo::messages).
  void report_to(std::FILE* messages) { messages_ = messages; }
  std::FILE* messages() const { return messages_; }

  // /particles/all/species, once. `names` are stored as an attribute (index -> name).
  void write_species(const std::int32_t* species, std::size_t n, const std::vector<std::string>& names);

  // Declare the time-dependent element /particles/all/<name> holding n x components values of
  // `dtype` per frame, then append frames to it (`data`: n*components values of that dtype).
  // has_particle_element: declared, or found by reopen().
  bool has_particle_element(const std::string& name) const;
  void add_particle_element(const std::string& name, DType dtype, std::size_t n, int components);
  void append_particle_element(const std::string& name, std::int64_t step, double time, const void* data);

  // /observables/<name>: created on first use. A row at or before the series' last step is
  // not written: it holds a value the file has (a metric not reported again since).
  void append_observable(const std::string& name, std::int64_t step, double time, double value);

  // /connectivity/<name>: m triangles (3 particle indices each); created on first use.
  void append_connectivity(const std::string& name, std::int64_t step, double time,
                           const std::int32_t* triangles, std::size_t m);

  // Make everything appended so far durable and readable by another process.
  void flush();
  // RunError when the file's disk has too little space left for a frame of `frame_bytes` (with
  // the chunks and metadata HDF5 may add): called before a frame is begun, because a write that
  // runs out of space mid-frame leaves a file HDF5 may not be able to read or close.
  void check_space(std::uint64_t frame_bytes) const;

  // Close the file. completed: rename the .partial to path() (RunError if that fails, the
  // .partial is kept). Not completed: keep the .partial and print where it is (messages()).
  void close(bool completed);

 private:
  struct Impl;
  H5mdWriter() = default;
  std::string path_;
  std::unique_ptr<Impl> impl_;
  std::FILE* messages_ = stderr;
};

// Whether this process's HDF5 library may be called from several threads at once (a thread-safe
// build, as Debian's): runs of `pipeline sweep --in-process` write their files from their own
// threads, and refuse to start without it.
bool hdf5_thread_safe();

}  // namespace ff
