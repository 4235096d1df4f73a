// The simulation state: a plain struct of named fields plus the box and the clock.
// Topology (triangulation, neighbour lists) is stored as fields too, so snapshots, copies
// between host and device, and output treat it like any per-particle data.
#pragma once
#include <array>
#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <set>
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
// u32, 1 component: the particle's number in the whole system, in a decomposed team only (core/run/domain.h),
// where a rank holds some particles in its own order; alone a particle's index is its id.
inline constexpr const char* particle_id = "particle.id";
// The particle.id of the fixed vertices a decomposed team adds beyond the band (Scheduling::fills_gap).
inline constexpr std::uint32_t kFillId = 0xffffffffu;
}  // namespace fields

class State {
 public:
  State(int dim, Precision precision, std::size_t n);

  int dim() const { return dim_; }
  Precision precision() const { return precision_; }
  DType real() const { return real_dtype(precision_); }
  std::size_t n() const { return n_; }
  // Particles [0, n_owned()) are this rank's own; [n_owned(), n()) are ghosts, copies of other
  // ranks' particles near this rank's slab (a decomposed team, core/run/domain.h). Alone, and in a
  // replicated team, every particle is owned: n_owned() == n(). A stage whose Scheduling::team
  // is TeamWork::decomposed computes results for the owned particles only.
  std::size_t n_owned() const { return n_owned_; }
  // Bumped whenever the particles held change (a decomposed team's migration, which renumbers
  // them): per-rank data derived from particle indices (a Verlet list) must be rebuilt then.
  std::uint64_t particles_version() const { return particles_version_; }

  Box box;
  std::vector<std::string> species;  // names, indexed by the `type` field
  std::vector<double> species_diameter;

  // The clock: advanced by the core after an accepted step.
  std::uint64_t step = 0;
  double time = 0.0;

  // Add a field; adding an existing name with the same dtype/components/count returns it,
  // anything else is an error (two stages disagree about a field).
  Field& add_field(const std::string& name, DType dtype, int components, std::size_t count);
  // A field with one entry per particle: recorded as such, so a decomposed team moves its
  // entries with the particles (migration, ghosts, gathering for observers).
  Field& add_particle_field(const std::string& name, DType dtype, int components);
  bool is_particle_field(const std::string& name) const { return particle_fields_.count(name) != 0; }
  std::vector<std::string> particle_field_names() const;
  // A decomposed team's migration (core/run/domain.cpp) after it resized and rewrote every
  // particle field to hold n particles, the first `owned` of them this rank's.
  void set_particles(std::size_t n, std::size_t owned);
  Field& field(const std::string& name);
  const Field& field(const std::string& name) const;
  // The same by a C string: the stages name fields by constants (fields::position), so the
  // name's address finds a remembered field first, checked against the field's own name (a
  // buffer reused for another name finds the right field too). The stages look fields up every
  // step, and a map lookup by name was a visible share of the host's own time a step on CUDA
  // (measured in bench/experiments/README.md, "The host's own time, sampled").
  Field& field(const char* name);
  const Field& field(const char* name) const;
  bool has_field(const std::string& name) const { return fields_.count(name) != 0; }
  std::vector<std::string> field_names() const;

 private:
  int dim_;
  Precision precision_;
  std::size_t n_;
  std::size_t n_owned_;
  std::uint64_t particles_version_ = 0;
  std::set<std::string> particle_fields_;
  std::map<std::string, std::unique_ptr<Field>> fields_;
  // field(const char*)'s memo, by the name's address: fields are never removed or moved, so a
  // remembered Field* stays valid; slots are overwritten freely (any thread: atomics).
  static constexpr std::size_t kNameSlots = 32;
  mutable std::array<std::atomic<Field*>, kNameSlots> by_name_address_{};
  Field* remembered(const char* name) const;
  Field* lookup(const std::string& name) const;  // by the map; throws when there is none
};

}  // namespace ff
