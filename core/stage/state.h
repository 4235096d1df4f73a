// The simulation state: a plain struct of named fields plus the box and the clock.
// Topology (triangulation, neighbour lists) is stored as fields too, so snapshots, copies
// between host and device, and output treat it like any per-particle data.
#pragma once
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/backend/field.h"
#include "core/base/types.h"

namespace ff {

struct Box {
  int dim = 2;
  double L[3] = {0, 0, 0};
  double volume() const { return dim == 2 ? L[0] * L[1] : L[0] * L[1] * L[2]; }
};

// Names of the fields every run has.
namespace fields {
inline constexpr const char* position = "position";  // real, dim components, wrapped into the box
inline constexpr const char* image = "image";        // i32, dim components: box crossings
inline constexpr const char* type = "type";          // i32, 1 component: species index
inline constexpr const char* diameter = "diameter";  // real, 1 component: sigma of the species
}  // namespace fields

class State {
 public:
  State(int dim, Precision precision, std::size_t n);

  int dim() const { return dim_; }
  Precision precision() const { return precision_; }
  DType real() const { return real_dtype(precision_); }
  std::size_t n() const { return n_; }

  Box box;
  std::vector<std::string> species;  // names, indexed by the `type` field
  std::vector<double> species_diameter;

  // The clock: advanced by the core after an accepted step.
  std::uint64_t step = 0;
  double time = 0.0;

  // Add a field; adding an existing name with the same dtype/components/count returns it,
  // anything else is an error (two stages disagree about a field).
  Field& add_field(const std::string& name, DType dtype, int components, std::size_t count);
  Field& add_particle_field(const std::string& name, DType dtype, int components) {
    return add_field(name, dtype, components, n_);
  }
  Field& field(const std::string& name);
  const Field& field(const std::string& name) const;
  bool has_field(const std::string& name) const { return fields_.count(name) != 0; }
  std::vector<std::string> field_names() const;

 private:
  int dim_;
  Precision precision_;
  std::size_t n_;
  std::map<std::string, std::unique_ptr<Field>> fields_;
};

}  // namespace ff
