#include "core/io/h5md_writer.h"

#include <hdf5.h>
#include <pwd.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <stdexcept>

#include "core/base/error.h"
#include "core/base/version.h"

namespace ff {

namespace {

// ---- errors -----------------------------------------------------------------------------

// HDF5 prints its error stack by default; the writer reports through exceptions instead.
class QuietErrors {
 public:
  QuietErrors() {
    H5Eget_auto2(H5E_DEFAULT, &func_, &data_);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  ~QuietErrors() { H5Eset_auto2(H5E_DEFAULT, func_, data_); }

 private:
  H5E_auto2_t func_ = nullptr;
  void* data_ = nullptr;
};

herr_t collect_error(unsigned n, const H5E_error2_t* e, void* out) {
  auto& s = *static_cast<std::string*>(out);
  if (n < 3 && e->desc && *e->desc) s += (s.empty() ? "" : "; ") + std::string(e->desc);
  return 0;
}

std::string hdf5_error() {
  std::string s;
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_DOWNWARD, collect_error, &s);
  return s.empty() ? "unknown HDF5 error" : s;
}

// The login name for /h5md/author: $USER, else the password database, else "unknown".
std::string user_name() {
  if (const char* u = std::getenv("USER"); u && *u) return u;
  if (const passwd* pw = getpwuid(getuid()); pw && pw->pw_name) return pw->pw_name;
  return "unknown";
}

// ---- RAII handle ------------------------------------------------------------------------

class Hid {
 public:
  using Closer = herr_t (*)(hid_t);
  Hid() = default;
  Hid(hid_t id, Closer close) : id_(id), close_(close) {}
  Hid(Hid&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = -1; }
  Hid& operator=(Hid&& o) noexcept {
    if (this != &o) {
      reset();
      id_ = o.id_;
      close_ = o.close_;
      o.id_ = -1;
    }
    return *this;
  }
  Hid(const Hid&) = delete;
  Hid& operator=(const Hid&) = delete;
  ~Hid() { reset(); }
  hid_t get() const { return id_; }
  hid_t release() {
    const hid_t id = id_;
    id_ = -1;
    return id;
  }
  void reset() {
    if (id_ >= 0 && close_) close_(id_);
    id_ = -1;
  }

 private:
  hid_t id_ = -1;
  Closer close_ = nullptr;
};

// ---- types ------------------------------------------------------------------------------

hid_t file_type(DType t) {
  switch (t) {
    case DType::f32: return H5T_IEEE_F32LE;
    case DType::f64: return H5T_IEEE_F64LE;
    case DType::i32: return H5T_STD_I32LE;
    case DType::u32: return H5T_STD_U32LE;
    case DType::i64: return H5T_STD_I64LE;
    case DType::u64: return H5T_STD_U64LE;
    case DType::u8: return H5T_STD_U8LE;
  }
  return -1;
}

hid_t memory_type(DType t) {
  switch (t) {
    case DType::f32: return H5T_NATIVE_FLOAT;
    case DType::f64: return H5T_NATIVE_DOUBLE;
    case DType::i32: return H5T_NATIVE_INT32;
    case DType::u32: return H5T_NATIVE_UINT32;
    case DType::i64: return H5T_NATIVE_INT64;
    case DType::u64: return H5T_NATIVE_UINT64;
    case DType::u8: return H5T_NATIVE_UINT8;
  }
  return -1;
}

// One time-dependent H5MD element: {step, time, value}.
struct Series {
  Hid group, step, time, value;
  DType dtype = DType::f64;
  std::vector<hsize_t> frame;  // shape of one frame; frame[0] grows for variable row counts
  bool variable_rows = false;
  hsize_t frames = 0;
};

}  // namespace

// ---- the file ---------------------------------------------------------------------------

struct H5mdWriter::Impl {
  std::string partial;
  Hid file, particles, observables, connectivity;
  std::map<std::string, Series> elements, scalars, topologies;

  void check(bool ok, const std::string& what) const {
    if (!ok) throw RunError("H5MD file '" + partial + "': " + what + " failed: " + hdf5_error());
  }
  Hid group(hid_t parent, const std::string& name) const {
    Hid lcpl(H5Pcreate(H5P_LINK_CREATE), H5Pclose);
    H5Pset_create_intermediate_group(lcpl.get(), 1);
    Hid g(H5Gcreate2(parent, name.c_str(), lcpl.get(), H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
    check(g.get() >= 0, "creating group '" + name + "'");
    return g;
  }

  // -- attributes --
  void attr(hid_t obj, const std::string& name, hid_t ftype, hid_t mtype, std::vector<hsize_t> dims,
            const void* data) const {
    Hid space(dims.empty() ? H5Screate(H5S_SCALAR) : H5Screate_simple(int(dims.size()), dims.data(), nullptr),
              H5Sclose);
    Hid a(H5Acreate2(obj, name.c_str(), ftype, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
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
    Hid t = string_type(len);
    attr(obj, name, t.get(), t.get(), scalar ? std::vector<hsize_t>{} : std::vector<hsize_t>{v.size()},
         packed.data());
  }
  Hid string_type(std::size_t len) const {
    Hid t(H5Tcopy(H5T_C_S1), H5Tclose);
    check(t.get() >= 0 && H5Tset_size(t.get(), len) >= 0 && H5Tset_strpad(t.get(), H5T_STR_NULLPAD) >= 0 &&
              H5Tset_cset(t.get(), H5T_CSET_UTF8) >= 0,
          "making a string type");
    return t;
  }

  // -- datasets --
  Hid dataset(hid_t parent, const std::string& name, hid_t ftype, std::vector<hsize_t> dims,
              std::vector<hsize_t> maxdims, std::vector<hsize_t> chunk, const void* fill) const {
    Hid space(H5Screate_simple(int(dims.size()), dims.data(), maxdims.empty() ? nullptr : maxdims.data()), H5Sclose);
    Hid dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
    if (!chunk.empty()) check(H5Pset_chunk(dcpl.get(), int(chunk.size()), chunk.data()) >= 0, "chunking " + name);
    if (fill) check(H5Pset_fill_value(dcpl.get(), ftype, fill) >= 0, "fill value of " + name);
    Hid d(H5Dcreate2(parent, name.c_str(), ftype, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT), H5Dclose);
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
    Hid fs(H5Dget_space(d), H5Sclose);
    Hid ms(H5Screate_simple(1, &one, nullptr), H5Sclose);
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
    for (hsize_t c : count)
      if (c == 0) return;  // an empty frame: the fill value stands
    Hid fs(H5Dget_space(s.value.get()), H5Sclose);
    Hid ms(H5Screate_simple(int(count.size()), count.data(), nullptr), H5Sclose);
    check(H5Sselect_hyperslab(fs.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr) >= 0 &&
              H5Dwrite(s.value.get(), memory_type(s.dtype), ms.get(), fs.get(), H5P_DEFAULT, data) >= 0,
          "writing a frame");
  }

  void write_header(const H5mdHeader& h) const {
    Hid h5md = group(file.get(), "h5md");
    attr_int(h5md.get(), "version", {1, 1}, false);
    const std::string author = h.author.empty() ? user_name() : h.author;
    attr_strings(group(h5md.get(), "author").get(), "name", {author}, true);
    Hid creator = group(h5md.get(), "creator");
    attr_strings(creator.get(), "name", {"flipflow"}, true);
    attr_strings(creator.get(), "version", {FF_VERSION_STRING}, true);

    Hid box = group(particles.get(), "box");
    attr_int(box.get(), "dimension", {h.dim}, true);
    attr_strings(box.get(), "boundary", std::vector<std::string>(std::size_t(h.dim), "periodic"), false);
    Hid edges = dataset(box.get(), "edges", H5T_IEEE_F64LE, {hsize_t(h.dim)}, {}, {}, nullptr);
    check(H5Dwrite(edges.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, h.edges) >= 0, "writing box edges");

    Hid params = group(file.get(), "parameters");
    for (auto& kv : h.run_attributes) attr_strings(params.get(), kv.first, {kv.second}, true);
    if (!h.pipeline_text.empty()) {
      Hid t = string_type(h.pipeline_text.size());
      Hid space(H5Screate(H5S_SCALAR), H5Sclose);
      Hid d(H5Dcreate2(params.get(), "pipeline", t.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
            H5Dclose);
      check(d.get() >= 0 && H5Dwrite(d.get(), t.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, h.pipeline_text.data()) >= 0,
            "writing /parameters/pipeline");
    }
  }
};

H5mdWriter::H5mdWriter(std::string path, const H5mdHeader& header) : path_(std::move(path)) {
  if (header.dim != 2 && header.dim != 3) throw std::invalid_argument("H5mdWriter: dimension must be 2 or 3");
  QuietErrors quiet;
  auto impl = std::make_unique<Impl>();
  impl->partial = partial_path();
  Hid fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG);
  impl->file = Hid(H5Fcreate(impl->partial.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.get()), H5Fclose);
  if (impl->file.get() < 0)
    throw RunError("cannot create the H5MD file '" + impl->partial + "': " + hdf5_error() +
                   " (does the directory exist and is it writable?)");
  impl->particles = impl->group(impl->file.get(), "particles/all");
  impl->observables = impl->group(impl->file.get(), "observables");
  impl->write_header(header);
  impl_ = std::move(impl);
  flush();
}

H5mdWriter::~H5mdWriter() {
  if (!impl_) return;
  try {
    close(false);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "flipflow: closing '%s' failed: %s\n", partial_path().c_str(), e.what());
  }
}

void H5mdWriter::write_species(const std::int32_t* species, std::size_t n, const std::vector<std::string>& names) {
  QuietErrors quiet;
  Hid d = impl_->dataset(impl_->particles.get(), "species", H5T_STD_I32LE, {hsize_t(n)}, {}, {}, nullptr);
  if (n)
    impl_->check(H5Dwrite(d.get(), H5T_NATIVE_INT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, species) >= 0,
                 "writing species");
  if (!names.empty()) impl_->attr_strings(d.get(), "names", names, false);
}

void H5mdWriter::add_particle_element(const std::string& name, DType dtype, std::size_t n, int components) {
  if (impl_->elements.count(name)) throw std::logic_error("H5MD element '" + name + "' declared twice");
  QuietErrors quiet;
  std::vector<hsize_t> frame{hsize_t(n)};
  if (components != 1) frame.push_back(hsize_t(components));
  impl_->elements[name] = impl_->series(impl_->particles.get(), name, dtype, frame, false, nullptr);
}

void H5mdWriter::append_particle_element(const std::string& name, std::int64_t step, double time, const void* data) {
  auto it = impl_->elements.find(name);
  if (it == impl_->elements.end()) throw std::logic_error("H5MD element '" + name + "' was not declared");
  QuietErrors quiet;
  impl_->append(it->second, step, time, data, 0);
}

void H5mdWriter::append_observable(const std::string& name, std::int64_t step, double time, double value) {
  QuietErrors quiet;
  auto it = impl_->scalars.find(name);
  if (it == impl_->scalars.end())
    it = impl_->scalars.emplace(name, impl_->series(impl_->observables.get(), name, DType::f64, {}, false, nullptr))
             .first;
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
  impl->particles.reset();
  impl->observables.reset();
  impl->connectivity.reset();
  const hid_t file = impl->file.release();  // closed here, where its status is checked
  if (H5Fclose(file) < 0)
    throw RunError("closing the H5MD file '" + partial + "' failed: " + hdf5_error() +
                   "; the partial trajectory is kept at '" + partial + "'");
  if (!completed) {
    std::fprintf(stderr, "flipflow: the run did not complete; the partial trajectory is kept at '%s'\n",
                 partial.c_str());
    return;
  }
  std::error_code ec;
  std::filesystem::rename(partial, path_, ec);
  if (ec)
    throw RunError("cannot rename '" + partial + "' to '" + path_ + "': " + ec.message() +
                   "; the complete trajectory is kept at '" + partial + "'");
}

}  // namespace ff
