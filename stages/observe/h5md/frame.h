// One output frame copied out of the state: what observe.h5md hands its writer thread.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "core/io/h5md_writer.h"
#include "core/backend/host_buffer.h"

namespace ff::observe {

struct FieldFrame {
  std::string name;           // element name (the field's name)
  bool connectivity = false;  // true: /connectivity/<name> (triangles); false: /particles/all/<name>
  std::size_t count = 0;      // elements this frame (triangles for connectivity)
  HostBuffer bytes;           // pinned in CUDA runs: filled by an asynchronous device copy
};

// One observable's row: its value and the step and time it was measured at, which for a metric
// of a stage that skips steps is earlier than the frame's.
struct ObservableRow {
  std::string name;
  std::int64_t step = 0;
  double time = 0;
  double value = 0;
};

struct Frame {
  std::int64_t step = 0;
  double time = 0;
  std::vector<FieldFrame> fields;
  bool with_fields = true;  // false: an observables-only row (frames_every); `fields` keeps its buffers for later frames
  std::vector<ObservableRow> observables;
  StreamMark ready;  // CUDA runs: the frame's device copies are done once this is reached
};

// Wait for the frame's device copies (if any), append every field (when with_fields) and
// observable of `f` to `w`, then flush (a killed run keeps this frame).
void write_frame(H5mdWriter& w, Frame& f);

}  // namespace ff::observe
