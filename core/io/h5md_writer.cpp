#include "core/io/h5md_writer.h"

#include <hdf5.h>
#include <pwd.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <stdexcept>

#include "core/base/error.h"
#include "core/base/version.h"
#include "core/io/hdf5_common.h"

namespace ff {

namespace {

using hdf5::Handle;
using hdf5::QuietErrors;
using hdf5::file_type;
using hdf5::memory_type;

// The login name for /h5md/author: $USER, else the password database, else "unknown".
std::string user_name() {
  if (const char* u = std::getenv("USER"); u && *u) return u;
  // (getpwuid_r: runs of an in-process sweep may ask at once.)
  passwd entry{};
  passwd* pw = nullptr;
  char buf[4096];
  if (getpwuid_r(getuid(), &entry, buf, sizeof buf, &pw) == 0 && pw && pw->pw_name) return pw->pw_name;
  return "unknown";
}

// ---- types ------------------------------------------------------------------------------

// One time-dependent H5MD element: {step, time, value}.
struct Series {
  Handle group, step, time, value;
  DType dtype = DType::f64;
  std::vector<hsize_t> frame;  // shape of one frame; frame[0] grows for variable row counts
  bool variable_rows = false;
  hsize_t frames = 0;
  std::int64_t last_step = 0;  // the step of row frames - 1 (when frames > 0)
  int padded_from = 0;  // components in the caller's data when the file pads them (0: none)
};

// The nominal box height of a 2-D run written for 3-D-only readers (docs in the header).
constexpr double kNominalLz = 1.0;

}  // namespace

// ---- the file ---------------------------------------------------------------------------

struct H5mdWriter::Impl {
  std::string partial;
  Handle file, particles, observables, connectivity;
  std::map<std::string, Series> elements, scalars, topologies;
  bool readers_layout = false;  // the 3-D-only readers' layout (header)
  bool pad_to_3d = false;       // ... of a 2-D run
  Series box_edges;             // time-dependent box/edges (that layout only)
  double edges[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};  // the box matrix (diagonal) of its rows
  std::vector<std::int64_t> frame_steps;  // step and time of every box/edges row (that layout)
  std::vector<double> frame_times;

  // The readers' layout: one box row per frame, written with the frame's first element.
  void append_box_row(std::int64_t step, double time) {
    append(box_edges, step, time, edges, 0);
    frame_steps.push_back(step);
    frame_times.push_back(time);
  }
  // The readers' layout: an observable that skipped frames (a stage metric that appears after
  // the first frame) gets NaN rows there, so its row k is the frame k of the particles.
  void pad_observable(Series& s) const {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    while (s.frames + 1 < frame_steps.size())
      append(s, frame_steps[s.frames], frame_times[s.frames], &nan, 0);
  }

  mutable bool failed = false;  // a write or flush failed (a full disk): close() keeps the file openable
  void check(bool ok, const std::string& what) const {
    if (!ok) failed = true;
    if (!ok) throw RunError("H5MD file '" + partial + "': " + what + " failed: " + hdf5::error_text());
  }
  Handle group(hid_t parent, const std::string& name) const {
    Handle lcpl(H5Pcreate(H5P_LINK_CREATE), H5Pclose);
    H5Pset_create_intermediate_group(lcpl.get(), 1);
    Handle g(H5Gcreate2(parent, name.c_str(), lcpl.get(), H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
    check(g.get() >= 0, "creating group '" + name + "'");
    return g;
  }

  // -- attributes --
  void attr(hid_t obj, const std::string& name, hid_t ftype, hid_t mtype, std::vector<hsize_t> dims,
            const void* data) const {
    Handle space(dims.empty() ? H5Screate(H5S_SCALAR) : H5Screate_simple(int(dims.size()), dims.data(), nullptr),
              H5Sclose);
    Handle a(H5Acreate2(obj, name.c_str(), ftype, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
    check(a.get() >= 0 && H5Awrite(a.get(), mtype, data) >= 0, "writing attribute '" + name + "'");
  }
  void attr_int(hid_t obj, const std::string& name, std::vector<int> v, bool scalar) const {
    attr(obj, name, H5T_STD_I32LE, H5T_NATIVE_INT, scalar ? std::vector<hsize_t>{} : std::vector<hsize_t>{v.size()},
         v.data());
  }
  // Fixed-length UTF-8 strings, padded with NULs: a scalar for one, a 1-D array for several.
  void attr_strings(hid_t obj, const std::string& name, const std::vector<std::string>& v, bool scalar) const {
    std::size_t len = 1;
    for (auto& s : v) len = std::max(len, s.size());
    std::string packed(len * v.size(), '\0');
    for (std::size_t i = 0; i < v.size(); ++i) packed.replace(i * len, v[i].size(), v[i]);
    Handle t = string_type(len);
    attr(obj, name, t.get(), t.get(), scalar ? std::vector<hsize_t>{} : std::vector<hsize_t>{v.size()},
         packed.data());
  }
  Handle string_type(std::size_t len) const {
    Handle t(H5Tcopy(H5T_C_S1), H5Tclose);
    check(t.get() >= 0 && H5Tset_size(t.get(), len) >= 0 && H5Tset_strpad(t.get(), H5T_STR_NULLPAD) >= 0 &&
              H5Tset_cset(t.get(), H5T_CSET_UTF8) >= 0,
          "making a string type");
    return t;
  }

  // -- datasets --
  Handle dataset(hid_t parent, const std::string& name, hid_t ftype, std::vector<hsize_t> dims,
              std::vector<hsize_t> maxdims, std::vector<hsize_t> chunk, const void* fill) const {
    Handle space(H5Screate_simple(int(dims.size()), dims.data(), maxdims.empty() ? nullptr : maxdims.data()), H5Sclose);
    Handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
    if (!chunk.empty()) check(H5Pset_chunk(dcpl.get(), int(chunk.size()), chunk.data()) >= 0, "chunking " + name);
    if (fill) check(H5Pset_fill_value(dcpl.get(), ftype, fill) >= 0, "fill value of " + name);
    Handle d(H5Dcreate2(parent, name.c_str(), ftype, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT), H5Dclose);
    check(d.get() >= 0, "creating dataset '" + name + "'");
    return d;
  }

  Series series(hid_t parent, const std::string& name, DType dtype, std::vector<hsize_t> frame, bool variable_rows,
                const void* fill) const {
    Series s;
    s.group = group(parent, name);
    s.dtype = dtype;
    s.frame = frame;
    s.variable_rows = variable_rows;
    const hsize_t index_chunk = 1024;
    s.step = dataset(s.group.get(), "step", H5T_STD_I64LE, {0}, {H5S_UNLIMITED}, {index_chunk}, nullptr);
    s.time = dataset(s.group.get(), "time", H5T_IEEE_F64LE, {0}, {H5S_UNLIMITED}, {index_chunk}, nullptr);
    // Chunks of ~256 KiB (at least one frame, at most 1024 frames).
    hsize_t frame_bytes = dtype_size(dtype);
    for (hsize_t d : frame) frame_bytes *= std::max<hsize_t>(d, 1);
    const hsize_t frames_per_chunk = std::clamp<hsize_t>((256u << 10) / frame_bytes, 1, 1024);
    std::vector<hsize_t> dims{0}, maxdims{H5S_UNLIMITED}, chunk{frames_per_chunk};
    for (std::size_t k = 0; k < frame.size(); ++k) {
      dims.push_back(frame[k]);
      // A zero-sized fixed axis cannot hold a chunk: leave it unlimited (it never grows).
      maxdims.push_back((variable_rows && k == 0) || frame[k] == 0 ? H5S_UNLIMITED : frame[k]);
      chunk.push_back(std::max<hsize_t>(frame[k], 1));
    }
    s.value = dataset(s.group.get(), "value", file_type(dtype), dims, maxdims, chunk, fill);
    return s;
  }

  // Write one value at `index` of an extendible 1-D dataset (growing it to index + 1).
  void put(hid_t d, hsize_t index, hid_t mtype, const void* v) const {
    const hsize_t size = index + 1, one = 1;
    check(H5Dset_extent(d, &size) >= 0, "extending a step/time series");
    Handle fs(H5Dget_space(d), H5Sclose);
    Handle ms(H5Screate_simple(1, &one, nullptr), H5Sclose);
    check(H5Sselect_hyperslab(fs.get(), H5S_SELECT_SET, &index, nullptr, &one, nullptr) >= 0 &&
              H5Dwrite(d, mtype, ms.get(), fs.get(), H5P_DEFAULT, v) >= 0,
          "writing a step/time value");
  }

  // Append one frame; `rows` replaces frame[0] for variable-row series.
  void append(Series& s, std::int64_t step, double time, const void* data, hsize_t rows) const {
    const hsize_t f = s.frames;
    put(s.step.get(), f, H5T_NATIVE_INT64, &step);
    put(s.time.get(), f, H5T_NATIVE_DOUBLE, &time);
    std::vector<hsize_t> count{1}, start(s.frame.size() + 1, 0);
    start[0] = f;
    if (s.variable_rows) s.frame[0] = std::max(s.frame[0], rows);
    std::vector<hsize_t> dims{f + 1};
    for (std::size_t k = 0; k < s.frame.size(); ++k) {
      dims.push_back(s.frame[k]);
      count.push_back(s.variable_rows && k == 0 ? rows : s.frame[k]);
    }
    check(H5Dset_extent(s.value.get(), dims.data()) >= 0, "extending a value dataset");
    s.frames = f + 1;
    s.last_step = step;
    for (hsize_t c : count)
      if (c == 0) return;  // an empty frame: the fill value stands
    std::vector<unsigned char> padded;
    if (s.padded_from) {  // rows of padded_from values -> rows of frame[1] values, zeros after
      const std::size_t size = dtype_size(s.dtype), rows = s.frame[0];
      const std::size_t in_row = size * std::size_t(s.padded_from), out_row = size * std::size_t(s.frame[1]);
      padded.assign(rows * out_row, 0);
      for (std::size_t i = 0; i < rows; ++i)
        std::memcpy(padded.data() + i * out_row, static_cast<const unsigned char*>(data) + i * in_row, in_row);
      data = padded.data();
    }
    Handle fs(H5Dget_space(s.value.get()), H5Sclose);
    Handle ms(H5Screate_simple(int(count.size()), count.data(), nullptr), H5Sclose);
    check(H5Sselect_hyperslab(fs.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr) >= 0 &&
              H5Dwrite(s.value.get(), memory_type(s.dtype), ms.get(), fs.get(), H5P_DEFAULT, data) >= 0,
          "writing a frame");
  }

  void write_header(const H5mdHeader& h) const {
    Handle h5md = group(file.get(), "h5md");
    attr_int(h5md.get(), "version", {1, 1}, false);
    const std::string author = h.author.empty() ? user_name() : h.author;
    attr_strings(group(h5md.get(), "author").get(), "name", {author}, true);
    Handle creator = group(h5md.get(), "creator");
    attr_strings(creator.get(), "name", {"flipflow"}, true);
    attr_strings(creator.get(), "version", {FF_VERSION_STRING}, true);

    Handle box = group(particles.get(), "box");
    if (pad_to_3d) {
      attr_int(box.get(), "dimension", {3}, true);
      attr_strings(box.get(), "boundary", {"periodic", "periodic", "none"}, false);
      attr_int(box.get(), "flipflow_dimension", {2}, true);
    } else if (readers_layout) {
      attr_int(box.get(), "dimension", {h.dim}, true);
      attr_strings(box.get(), "boundary", std::vector<std::string>(std::size_t(h.dim), "periodic"), false);
    } else {
      attr_int(box.get(), "dimension", {h.dim}, true);
      attr_strings(box.get(), "boundary", std::vector<std::string>(std::size_t(h.dim), "periodic"), false);
      Handle edges = dataset(box.get(), "edges", H5T_IEEE_F64LE, {hsize_t(h.dim)}, {}, {}, nullptr);
      check(H5Dwrite(edges.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, h.edges) >= 0,
            "writing box edges");
    }

    Handle params = group(file.get(), "parameters");
    for (auto& kv : h.run_attributes) attr_strings(params.get(), kv.first, {kv.second}, true);
    if (!h.pipeline_text.empty()) {
      Handle t = string_type(h.pipeline_text.size());
      Handle space(H5Screate(H5S_SCALAR), H5Sclose);
      Handle d(H5Dcreate2(params.get(), "pipeline", t.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
            H5Dclose);
      check(d.get() >= 0 && H5Dwrite(d.get(), t.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, h.pipeline_text.data()) >= 0,
            "writing /parameters/pipeline");
    }
    for (auto& [name, text] : h.texts) write_text(params.get(), name, text);
  }

  void write_text(hid_t parent, const std::string& name, const std::string& text) const {
    Handle t = string_type(std::max<std::size_t>(text.size(), 1));
    Handle space(H5Screate(H5S_SCALAR), H5Sclose);
    Handle d(H5Dcreate2(parent, name.c_str(), t.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose);
    std::string buf = text.empty() ? std::string(1, '\0') : text;
    check(d.get() >= 0 && H5Dwrite(d.get(), t.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()) >= 0,
          "writing /parameters/" + name);
  }

  // ---- continuing a file (reopen) ----

  // The names of the links in `g` that are groups.
  std::vector<std::string> subgroups(hid_t g) const {
    std::vector<std::string> names;
    auto collect = [](hid_t, const char* name, const H5L_info_t*, void* op) -> herr_t {
      static_cast<std::vector<std::string>*>(op)->push_back(name);
      return 0;
    };
    check(H5Literate(g, H5_INDEX_NAME, H5_ITER_INC, nullptr, collect, &names) >= 0, "listing a group");
    std::vector<std::string> out;
    for (auto& n : names) {
      // H5Oopen + H5Iget_type: one signature across HDF5 versions (H5Oget_info's changed).
      Handle obj(H5Oopen(g, n.c_str(), H5P_DEFAULT), H5Oclose);
      if (obj.get() >= 0 && H5Iget_type(obj.get()) == H5I_GROUP) out.push_back(n);
    }
    return out;
  }

  static bool has_link(hid_t g, const std::string& name) { return H5Lexists(g, name.c_str(), H5P_DEFAULT) > 0; }

  // Opens the series at g/name and keeps its frames with step <= last_step.
  Series open_series(hid_t g, const std::string& name, bool variable_rows, std::int64_t last_step) const {
    Series s;
    s.group = Handle(H5Gopen2(g, name.c_str(), H5P_DEFAULT), H5Gclose);
    check(s.group.get() >= 0, "opening '" + name + "'");
    s.step = Handle(H5Dopen2(s.group.get(), "step", H5P_DEFAULT), H5Dclose);
    s.time = Handle(H5Dopen2(s.group.get(), "time", H5P_DEFAULT), H5Dclose);
    s.value = Handle(H5Dopen2(s.group.get(), "value", H5P_DEFAULT), H5Dclose);
    check(s.step.get() >= 0 && s.time.get() >= 0 && s.value.get() >= 0, "opening the datasets of '" + name + "'");
    s.variable_rows = variable_rows;
    {
      Handle t(H5Dget_type(s.value.get()), H5Tclose);
      const H5T_class_t c = H5Tget_class(t.get());
      const std::size_t size = H5Tget_size(t.get());
      const bool sgn = c == H5T_INTEGER && H5Tget_sign(t.get()) == H5T_SGN_2;
      if (c == H5T_FLOAT) s.dtype = size == 4 ? DType::f32 : DType::f64;
      else if (size == 1) s.dtype = DType::u8;
      else if (size == 4) s.dtype = sgn ? DType::i32 : DType::u32;
      else s.dtype = sgn ? DType::i64 : DType::u64;
    }
    Handle vs(H5Dget_space(s.value.get()), H5Sclose);
    const int rank = H5Sget_simple_extent_ndims(vs.get());
    std::vector<hsize_t> dims(std::size_t(std::max(rank, 1)));
    H5Sget_simple_extent_dims(vs.get(), dims.data(), nullptr);
    s.frame.assign(dims.begin() + 1, dims.end());
    if (H5Aexists(s.value.get(), "flipflow_padded_from") > 0) {
      Handle a(H5Aopen(s.value.get(), "flipflow_padded_from", H5P_DEFAULT), H5Aclose);
      check(a.get() >= 0 && H5Aread(a.get(), H5T_NATIVE_INT, &s.padded_from) >= 0,
            "reading flipflow_padded_from of '" + name + "'");
    }
    Handle ss(H5Dget_space(s.step.get()), H5Sclose);
    hsize_t n = 0;
    H5Sget_simple_extent_dims(ss.get(), &n, nullptr);
    std::vector<std::int64_t> steps(n);
    if (n) check(H5Dread(s.step.get(), H5T_NATIVE_INT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, steps.data()) >= 0,
                 "reading the steps of '" + name + "'");
    hsize_t keep = 0;
    while (keep < n && steps[keep] <= last_step) ++keep;  // frames are appended in step order
    if (keep > 0) s.last_step = steps[keep - 1];
    if (keep < n) {
      check(H5Dset_extent(s.step.get(), &keep) >= 0 && H5Dset_extent(s.time.get(), &keep) >= 0,
            "dropping frames of '" + name + "'");
      dims[0] = keep;
      check(H5Dset_extent(s.value.get(), dims.data()) >= 0, "dropping frames of '" + name + "'");
    }
    s.frames = keep;
    return s;
  }

  // Every series under /observables (names "a/b" for nested groups).
  void open_observables(hid_t g, const std::string& prefix, std::int64_t last_step) {
    for (auto& name : subgroups(g)) {
      Handle sub(H5Gopen2(g, name.c_str(), H5P_DEFAULT), H5Gclose);
      if (has_link(sub.get(), "step") && has_link(sub.get(), "value")) {
        scalars[prefix + name] = open_series(g, name, false, last_step);
      } else {
        open_observables(sub.get(), prefix + name + "/", last_step);
      }
    }
  }
};

H5mdWriter::H5mdWriter(std::string path, const H5mdHeader& header) : path_(std::move(path)) {
  if (header.dim != 2 && header.dim != 3) throw std::invalid_argument("H5mdWriter: dimension must be 2 or 3");
  QuietErrors quiet;
  auto impl = std::make_unique<Impl>();
  impl->partial = partial_path();
  impl->readers_layout = header.readers_layout;
  impl->pad_to_3d = header.readers_layout && header.dim == 2;
  for (int k = 0; k < 3; ++k) impl->edges[4 * k] = header.edges[k];
  if (impl->pad_to_3d) impl->edges[8] = kNominalLz;
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG);
  impl->file = Handle(H5Fcreate(impl->partial.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.get()), H5Fclose);
  if (impl->file.get() < 0)
    throw RunError("cannot create the H5MD file '" + impl->partial + "': " + hdf5::error_text() +
                   " (does the directory exist and is it writable?)");
  impl->particles = impl->group(impl->file.get(), "particles/all");
  impl->observables = impl->group(impl->file.get(), "observables");
  impl->write_header(header);
  if (impl->readers_layout) {
    Handle box(H5Gopen2(impl->particles.get(), "box", H5P_DEFAULT), H5Gclose);
    impl->box_edges = impl->series(box.get(), "edges", DType::f64, {3, 3}, false, nullptr);
  }
  impl_ = std::move(impl);
  flush();
}

std::unique_ptr<H5mdWriter> H5mdWriter::reopen(std::string path, std::int64_t last_step,
                                               const std::vector<std::pair<std::string, std::string>>& history) {
  namespace fs = std::filesystem;
  QuietErrors quiet;
  const std::string partial = path + ".partial";
  if (!fs::exists(partial)) {
    if (!fs::exists(path)) return nullptr;
    std::error_code ec;
    fs::rename(path, partial, ec);
    if (ec) throw RunError("cannot rename '" + path + "' to '" + partial + "' to continue it: " + ec.message());
  }
  std::unique_ptr<H5mdWriter> w(new H5mdWriter());
  w->path_ = std::move(path);
  auto impl = std::make_unique<Impl>();
  impl->partial = partial;
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG);
  impl->file = Handle(H5Fopen(partial.c_str(), H5F_ACC_RDWR, fapl.get()), H5Fclose);
  if (impl->file.get() < 0)
    throw RunError("cannot open the H5MD file '" + partial + "' to continue it: " + hdf5::error_text() +
                   " (damaged by the crash? move it away to start the file afresh from the checkpoint)");
  const hid_t f = impl->file.get();
  if (!Impl::has_link(f, "particles") || !Impl::has_link(f, "observables"))
    throw RunError("'" + partial + "' is not an H5MD file flipflow wrote (no /particles or /observables)");
  impl->particles = Handle(H5Gopen2(f, "particles/all", H5P_DEFAULT), H5Gclose);
  impl->observables = Handle(H5Gopen2(f, "observables", H5P_DEFAULT), H5Gclose);
  impl->check(impl->particles.get() >= 0 && impl->observables.get() >= 0, "opening /particles/all");
  for (auto& name : impl->subgroups(impl->particles.get()))
    if (name != "box") impl->elements[name] = impl->open_series(impl->particles.get(), name, false, last_step);
  {
    Handle box(H5Gopen2(impl->particles.get(), "box", H5P_DEFAULT), H5Gclose);
    impl->check(box.get() >= 0, "opening /particles/all/box");
    if (impl->subgroups(box.get()) == std::vector<std::string>{"edges"}) {  // the 3-D-only readers' layout
      impl->readers_layout = true;
      impl->pad_to_3d = H5Aexists(box.get(), "flipflow_dimension") > 0;
      Series& e = impl->box_edges = impl->open_series(box.get(), "edges", false, last_step);
      const std::size_t rows = std::size_t(e.frames);
      std::vector<double> values(rows * 9);
      impl->frame_steps.resize(rows);
      impl->frame_times.resize(rows);
      if (rows) {
        const hsize_t start = 0, count = rows;
        Handle ss(H5Dget_space(e.step.get()), H5Sclose), ts(H5Dget_space(e.time.get()), H5Sclose);
        Handle ms(H5Screate_simple(1, &count, nullptr), H5Sclose);
        impl->check(H5Sselect_hyperslab(ss.get(), H5S_SELECT_SET, &start, nullptr, &count, nullptr) >= 0 &&
                        H5Sselect_hyperslab(ts.get(), H5S_SELECT_SET, &start, nullptr, &count, nullptr) >= 0 &&
                        H5Dread(e.step.get(), H5T_NATIVE_INT64, ms.get(), ss.get(), H5P_DEFAULT,
                                impl->frame_steps.data()) >= 0 &&
                        H5Dread(e.time.get(), H5T_NATIVE_DOUBLE, ms.get(), ts.get(), H5P_DEFAULT,
                                impl->frame_times.data()) >= 0 &&
                        H5Dread(e.value.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) >= 0,
                    "reading box/edges");
        std::copy(values.begin(), values.begin() + 9, impl->edges);
      }
    }
  }
  impl->open_observables(impl->observables.get(), "", last_step);
  if (Impl::has_link(f, "connectivity")) {
    impl->connectivity = Handle(H5Gopen2(f, "connectivity", H5P_DEFAULT), H5Gclose);
    for (auto& name : impl->subgroups(impl->connectivity.get()))
      impl->topologies[name] = impl->open_series(impl->connectivity.get(), name, true, last_step);
  }
  {
    Handle params = Impl::has_link(f, "parameters") ? Handle(H5Gopen2(f, "parameters", H5P_DEFAULT), H5Gclose)
                                                  : impl->group(f, "parameters");
    Handle hist = Impl::has_link(params.get(), "history") ? Handle(H5Gopen2(params.get(), "history", H5P_DEFAULT), H5Gclose)
                                                        : impl->group(params.get(), "history");
    Handle entry = impl->group(hist.get(), std::to_string(impl->subgroups(hist.get()).size()));
    for (auto& [k, v] : history) impl->attr_strings(entry.get(), k, {v}, true);
  }
  w->impl_ = std::move(impl);
  w->flush();
  return w;
}

bool H5mdWriter::has_particle_element(const std::string& name) const { return impl_->elements.count(name) != 0; }

H5mdWriter::~H5mdWriter() {
  if (!impl_) return;
  try {
    close(false);
  } catch (const std::exception& e) {
    std::fprintf(messages_, "flipflow: closing '%s' failed: %s\n", partial_path().c_str(), e.what());
  }
}

void H5mdWriter::write_species(const std::int32_t* species, std::size_t n, const std::vector<std::string>& names) {
  QuietErrors quiet;
  Handle d = impl_->dataset(impl_->particles.get(), "species", H5T_STD_I32LE, {hsize_t(n)}, {}, {}, nullptr);
  if (n)
    impl_->check(H5Dwrite(d.get(), H5T_NATIVE_INT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, species) >= 0,
                 "writing species");
  if (!names.empty()) impl_->attr_strings(d.get(), "names", names, false);
}

void H5mdWriter::add_particle_element(const std::string& name, DType dtype, std::size_t n, int components) {
  if (impl_->elements.count(name)) throw std::logic_error("H5MD element '" + name + "' declared twice");
  QuietErrors quiet;
  std::vector<hsize_t> frame{hsize_t(n)};
  const bool pad = impl_->pad_to_3d && components == 2;
  if (components != 1) frame.push_back(hsize_t(pad ? 3 : components));
  Series s = impl_->series(impl_->particles.get(), name, dtype, frame, false, nullptr);
  if (pad) {
    s.padded_from = 2;
    impl_->attr_int(s.value.get(), "flipflow_padded_from", {2}, true);
  }
  impl_->elements[name] = std::move(s);
}

void H5mdWriter::append_particle_element(const std::string& name, std::int64_t step, double time, const void* data) {
  auto it = impl_->elements.find(name);
  if (it == impl_->elements.end()) throw std::logic_error("H5MD element '" + name + "' was not declared");
  QuietErrors quiet;
  // The box row of this frame, with the frame's first element (the 3-D-only readers' layout).
  if (impl_->readers_layout && impl_->box_edges.frames == it->second.frames) impl_->append_box_row(step, time);
  impl_->append(it->second, step, time, data, 0);
}

void H5mdWriter::append_observable(const std::string& given, std::int64_t step, double time, double value) {
  QuietErrors quiet;
  std::string name = given;
  if (impl_->readers_layout) std::replace(name.begin(), name.end(), '/', '.');
  auto it = impl_->scalars.find(name);
  if (it == impl_->scalars.end())
    it = impl_->scalars.emplace(name, impl_->series(impl_->observables.get(), name, DType::f64, {}, false, nullptr))
             .first;
  // A series' steps increase: a row at or before its last is a value already written (a metric
  // not reported again, or one a continued file kept from before its checkpoint).
  if (it->second.frames > 0 && step <= it->second.last_step) return;
  if (impl_->readers_layout) impl_->pad_observable(it->second);
  impl_->append(it->second, step, time, &value, 0);
}

void H5mdWriter::append_connectivity(const std::string& name, std::int64_t step, double time,
                                     const std::int32_t* triangles, std::size_t m) {
  QuietErrors quiet;
  auto it = impl_->topologies.find(name);
  if (it == impl_->topologies.end()) {
    if (impl_->connectivity.get() < 0) impl_->connectivity = impl_->group(impl_->file.get(), "connectivity");
    const std::int32_t fill = -1;
    Series s = impl_->series(impl_->connectivity.get(), name, DType::i32, {hsize_t(m), 3}, true, &fill);
    hobj_ref_t ref;
    impl_->check(H5Rcreate(&ref, impl_->file.get(), "/particles/all", H5R_OBJECT, -1) >= 0,
                 "referencing /particles/all");
    impl_->attr(s.group.get(), "particles_group", H5T_STD_REF_OBJ, H5T_STD_REF_OBJ, {}, &ref);
    it = impl_->topologies.emplace(name, std::move(s)).first;
  }
  impl_->append(it->second, step, time, triangles, hsize_t(m));
}

void H5mdWriter::check_space(std::uint64_t frame_bytes) const {
  if (!impl_) return;
  const std::uint64_t free = hdf5::free_bytes(impl_->partial);
  // The frame, a new chunk for every series at worst (value chunks up to 256 KiB, step and time
  // chunks of 1 024 values), and the metadata a flush and a close write.
  const std::uint64_t series = impl_->elements.size() + impl_->scalars.size() + impl_->topologies.size() + 1;
  const std::uint64_t need = frame_bytes + series * ((256u << 10) + (16u << 10)) + (1u << 20);
  if (free < need)
    throw RunError("the disk holding '" + impl_->partial + "' has " + std::to_string(free >> 10) +
                   " KiB free, less than the next frame needs (" + std::to_string(need >> 10) +
                   " KiB with HDF5's chunks and metadata): stopped before writing it, so the file keeps every "
                   "frame before it, readable; free some space (a run that wrote checkpoints continues from the last with "
                   "--resume)");
}

void H5mdWriter::flush() {
  QuietErrors quiet;
  impl_->check(H5Fflush(impl_->file.get(), H5F_SCOPE_GLOBAL) >= 0, "flushing");
}

void H5mdWriter::close(bool completed) {
  if (!impl_) return;
  QuietErrors quiet;
  const std::string partial = partial_path();
  std::unique_ptr<Impl> impl = std::move(impl_);
  impl->elements.clear();
  impl->scalars.clear();
  impl->topologies.clear();
  impl->box_edges = Series();
  impl->particles.reset();
  impl->observables.reset();
  impl->connectivity.reset();
  const hid_t file = impl->file.release();  // closed here, where its status is checked
  // After a failed write (a full disk) the superblock on disk may already claim space that could
  // not be written, and HDF5 refuses to open a file shorter than that ("truncated file"), which
  // would lose every frame written before. Extending the file to the space HDF5 allocated (plus
  // room for what closing allocates) makes it openable again; the extension is a hole (sparse),
  // so it needs no disk space.
  haddr_t allocated = 0;
  if (impl->failed) {
    H5Fflush(file, H5F_SCOPE_GLOBAL);  // fails again, but allocates what it would write
    if (H5Fget_eoa(file, &allocated) < 0) allocated = 0;
  }
  const bool closed = H5Fclose(file) >= 0;
  if (impl->failed && allocated) {
    std::error_code ec;
    const std::uintmax_t want = std::uintmax_t(allocated) + (1u << 20);
    const std::uintmax_t size = std::filesystem::file_size(partial, ec);
    if (!ec && size < want) std::filesystem::resize_file(partial, want, ec);
    if (ec)
      std::fprintf(messages_, "flipflow: cannot extend '%s' after the failed write (%s); HDF5 may refuse to open it\n",
                   partial.c_str(), ec.message().c_str());
  }
  if (!closed)
    throw RunError("closing the H5MD file '" + partial + "' failed: " + hdf5::error_text() +
                   "; the partial trajectory is kept at '" + partial + "'");
  if (!completed) {
    std::fprintf(messages_, "flipflow: the run did not complete; the partial trajectory is kept at '%s'\n",
                 partial.c_str());
    return;
  }
  std::error_code ec;
  std::filesystem::rename(partial, path_, ec);
  if (ec)
    throw RunError("cannot rename '" + partial + "' to '" + path_ + "': " + ec.message() +
                   "; the complete trajectory is kept at '" + partial + "'");
}

bool hdf5_thread_safe() {
  hbool_t safe = 0;
  return H5is_library_threadsafe(&safe) >= 0 && safe;
}

}  // namespace ff
