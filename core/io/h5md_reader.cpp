#include "core/io/h5md_reader.h"

#include <hdf5.h>

#include <filesystem>

#include "core/base/error.h"
#include "core/io/hdf5_common.h"

namespace ff {

namespace {

using hdf5::QuietErrors;
using hdf5::Handle;

bool exists(hid_t f, const std::string& path) {
  // H5Lexists needs every parent to exist: check them one by one.
  std::size_t at = 1;
  while (true) {
    const auto slash = path.find('/', at);
    const std::string part = path.substr(0, slash);
    if (H5Lexists(f, part.c_str(), H5P_DEFAULT) <= 0) return false;
    if (slash == std::string::npos) return true;
    at = slash + 1;
  }
}

std::vector<hsize_t> dims_of(hid_t d) {
  Handle sp(H5Dget_space(d), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(sp.id);
  std::vector<hsize_t> dims(std::size_t(std::max(rank, 0)));
  if (rank > 0) H5Sget_simple_extent_dims(sp.id, dims.data(), nullptr);
  return dims;
}

template <class T>
std::vector<T> read_all(hid_t f, const std::string& path, hid_t mtype, const std::string& file) {
  Handle d(H5Dopen2(f, path.c_str(), H5P_DEFAULT), H5Dclose);
  if (d.id < 0) throw InputError("system.init.from: cannot open '" + path + "' in '" + file + "'");
  std::size_t count = 1;
  for (auto x : dims_of(d.id)) count *= x;
  std::vector<T> v(count);
  if (count && H5Dread(d.id, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0)
    throw InputError("system.init.from: cannot read '" + path + "' in '" + file + "'");
  return v;
}

// Row `row` of the time-dependent element at `group` (value [frames, n(, c)]), converted to T.
template <class T>
std::vector<T> read_frame(hid_t f, const std::string& group, hsize_t row, hid_t mtype, const std::string& file,
                          int& components) {
  Handle d(H5Dopen2(f, (group + "/value").c_str(), H5P_DEFAULT), H5Dclose);
  if (d.id < 0) throw InputError("system.init.from: cannot open '" + group + "/value' in '" + file + "'");
  auto dims = dims_of(d.id);
  if (dims.size() < 2 || row >= dims[0])
    throw InputError("system.init.from: '" + group + "/value' in '" + file + "' has no frame " + std::to_string(row));
  components = dims.size() > 2 ? int(dims[2]) : 1;
  std::vector<hsize_t> start(dims.size(), 0), count = dims;
  start[0] = row;
  count[0] = 1;
  Handle fs(H5Dget_space(d.id), H5Sclose);
  H5Sselect_hyperslab(fs.id, H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr);
  Handle ms(H5Screate_simple(int(count.size()), count.data(), nullptr), H5Sclose);
  std::size_t total = 1;
  for (auto x : count) total *= x;
  std::vector<T> v(total);
  if (H5Dread(d.id, mtype, ms.id, fs.id, H5P_DEFAULT, v.data()) < 0)
    throw InputError("system.init.from: cannot read frame " + std::to_string(row) + " of '" + group + "' in '" + file +
                     "'");
  return v;
}

// The row of `group` whose step is `step`; -1 when it has none.
std::int64_t row_of_step(hid_t f, const std::string& group, std::int64_t step, const std::string& file) {
  const auto steps = read_all<std::int64_t>(f, group + "/step", H5T_NATIVE_INT64, file);
  for (std::size_t k = 0; k < steps.size(); ++k)
    if (steps[k] == step) return std::int64_t(k);
  return -1;
}

}  // namespace

H5mdFrame read_h5md_frame(const std::string& path, std::int64_t frame) {
  QuietErrors quiet;
  if (!std::filesystem::exists(path))
    throw InputError("system.init.from: the file '" + path + "' does not exist" +
                     (std::filesystem::path(path).is_relative()
                          ? " (a relative path is read from the directory the command runs in, " +
                                std::filesystem::current_path().string() + ")"
                          : std::string()));
  Handle f(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (f.id < 0) throw InputError("system.init.from: '" + path + "' is not a readable HDF5 file");
  const std::string all = "/particles/all";
  if (!exists(f.id, all + "/position/value"))
    throw InputError("system.init.from: '" + path + "' has no " + all +
                     "/position (an H5MD file written by observe.h5md with `position` in its fields)");
  if (!exists(f.id, all + "/box/edges"))
    throw InputError("system.init.from: '" + path + "' has no " + all + "/box/edges");
  H5mdFrame out;
  const auto edges = read_all<double>(f.id, all + "/box/edges", H5T_NATIVE_DOUBLE, path);
  out.dim = int(edges.size());
  if (out.dim != 2 && out.dim != 3)
    throw InputError("system.init.from: the box in '" + path + "' has " + std::to_string(edges.size()) + " edges");
  for (int k = 0; k < out.dim; ++k) out.edges[k] = edges[std::size_t(k)];

  const auto steps = read_all<std::int64_t>(f.id, all + "/position/step", H5T_NATIVE_INT64, path);
  const auto times = read_all<double>(f.id, all + "/position/time", H5T_NATIVE_DOUBLE, path);
  const std::int64_t frames = std::int64_t(steps.size());
  const std::int64_t row = frame < 0 ? frames + frame : frame;
  if (row < 0 || row >= frames)
    throw InputError("system.init.from: frame " + std::to_string(frame) + " is out of range: '" + path + "' has " +
                     std::to_string(frames) + " frames (0 ... " + std::to_string(frames - 1) +
                     ", or -1 for the last)");
  out.frame = row;
  out.step = steps[std::size_t(row)];
  out.time = row < std::int64_t(times.size()) ? times[std::size_t(row)] : 0.0;
  int comps = 0;
  out.position = read_frame<double>(f.id, all + "/position", hsize_t(row), H5T_NATIVE_DOUBLE, path, comps);
  if (comps != out.dim)
    throw InputError("system.init.from: positions in '" + path + "' have " + std::to_string(comps) +
                     " components, the box " + std::to_string(out.dim));
  out.n = out.position.size() / std::size_t(out.dim);

  auto matching = [&](const std::string& name) -> std::int64_t {
    const std::string g = all + "/" + name;
    if (!exists(f.id, g + "/value")) return -1;
    const std::int64_t r = row_of_step(f.id, g, out.step, path);
    if (r < 0)
      throw InputError("system.init.from: '" + path + "' has " + name + " but no frame of it at step " +
                       std::to_string(out.step) + " (the position frame's step)");
    return r;
  };
  if (const std::int64_t r = matching("image"); r >= 0) {
    out.image = read_frame<std::int32_t>(f.id, all + "/image", hsize_t(r), H5T_NATIVE_INT32, path, comps);
  } else {
    out.image.assign(out.n * std::size_t(out.dim), 0);
  }
  if (const std::int64_t r = matching("type"); r >= 0) {
    out.species = read_frame<std::int32_t>(f.id, all + "/type", hsize_t(r), H5T_NATIVE_INT32, path, comps);
  } else if (exists(f.id, all + "/species")) {
    out.species = read_all<std::int32_t>(f.id, all + "/species", H5T_NATIVE_INT32, path);
  } else {
    out.species.assign(out.n, 0);
  }
  if (out.species.size() != out.n || out.image.size() != out.n * std::size_t(out.dim))
    throw InputError("system.init.from: species or image in '" + path + "' do not have one entry per particle");
  if (const std::int64_t r = matching("orientation"); r >= 0)
    out.orientation =
        read_frame<double>(f.id, all + "/orientation", hsize_t(r), H5T_NATIVE_DOUBLE, path, out.orientation_components);
  if (exists(f.id, all + "/species") && H5Aexists_by_name(f.id, (all + "/species").c_str(), "names", H5P_DEFAULT) > 0) {
    Handle a(H5Aopen_by_name(f.id, (all + "/species").c_str(), "names", H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
    Handle t(H5Aget_type(a.id), H5Tclose);
    Handle sp(H5Aget_space(a.id), H5Sclose);
    hsize_t count = 1;
    if (H5Sget_simple_extent_ndims(sp.id) == 1) H5Sget_simple_extent_dims(sp.id, &count, nullptr);
    const std::size_t len = H5Tget_size(t.id);
    if (H5Tis_variable_str(t.id) <= 0) {
      std::string buf(len * count, '\0');
      if (H5Aread(a.id, t.id, buf.data()) >= 0)
        for (hsize_t k = 0; k < count; ++k) {
          std::string s = buf.substr(k * len, len);
          while (!s.empty() && s.back() == '\0') s.pop_back();
          out.species_names.push_back(s);
        }
    }
  }
  return out;
}

}  // namespace ff
