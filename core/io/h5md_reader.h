// Reading one frame of an H5MD file (the layout core/io/h5md_writer.h writes; other writers'
// files work when they use the same names): what `system: {init: {from: FILE.h5, frame: k}}`
// starts a run from. No HDF5 types here.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace ff {

struct H5mdFrame {
  int dim = 0;
  std::size_t n = 0;
  double edges[3] = {0, 0, 0};        // /particles/all/box/edges
  std::int64_t frame = 0;             // the frame read (0-based; a negative request counted from the end)
  std::int64_t step = 0;              // its step and time
  double time = 0;
  std::vector<double> position;       // n x dim
  std::vector<std::int32_t> image;    // n x dim (zeros when the file has no image)
  std::vector<std::int32_t> species;  // n: the frame's `type` element, else /particles/all/species (else zeros)
  std::vector<std::string> species_names;  // the species dataset's `names` attribute (may be empty)
  std::vector<double> orientation;    // n x orientation_components, empty when the file has none
  int orientation_components = 0;
};

// Frame `frame` of /particles/all/position (negative: from the end, -1 the last) and the
// matching frames of image, type and orientation (matched by step). InputError naming the file
// and what is missing or out of range.
H5mdFrame read_h5md_frame(const std::string& path, std::int64_t frame);

}  // namespace ff
