#include "core/stage/state.h"

#include <cstring>
#include <stdexcept>

namespace ff {

State::State(int dim, Precision precision, std::size_t n) : dim_(dim), precision_(precision), n_(n), n_owned_(n) {
  if (dim != 2 && dim != 3) throw std::invalid_argument("dimensions must be 2 or 3");
  box.dim = dim;
  add_particle_field(fields::position, real(), dim);
  add_particle_field(fields::image, DType::i32, dim);
  add_particle_field(fields::type, DType::i32, 1);
  add_particle_field(fields::diameter, real(), 1);
}

Field& State::add_field(const std::string& name, DType dtype, int components, std::size_t count) {
  auto it = fields_.find(name);
  if (it != fields_.end()) {
    Field& f = *it->second;
    if (f.dtype() != dtype || f.components() != components || f.count() != count)
      throw std::logic_error("field '" + name + "' already exists with another shape (" +
                             to_string(f.dtype()) + " x" + std::to_string(f.components()) +
                             ", count " + std::to_string(f.count()) + ")");
    return f;
  }
  auto& slot = fields_[name];
  slot = std::make_unique<Field>(name, dtype, components, count);
  return *slot;
}

Field& State::add_particle_field(const std::string& name, DType dtype, int components) {
  Field& f = add_field(name, dtype, components, n_);
  particle_fields_.insert(name);
  return f;
}

std::vector<std::string> State::particle_field_names() const {
  return std::vector<std::string>(particle_fields_.begin(), particle_fields_.end());
}

void State::set_particles(std::size_t n, std::size_t owned) {
  if (owned > n) throw std::logic_error("State::set_particles: more owned particles than particles");
  for (auto& name : particle_fields_)
    if (field(name).count() != n)
      throw std::logic_error("State::set_particles: field '" + name + "' holds " + std::to_string(field(name).count()) +
                             " entries, not " + std::to_string(n));
  n_ = n;
  n_owned_ = owned;
  ++particles_version_;
}

Field* State::lookup(const std::string& name) const {
  auto it = fields_.find(name);
  if (it == fields_.end()) throw std::out_of_range("no field named '" + name + "'");
  return it->second.get();
}

Field& State::field(const std::string& name) { return *lookup(name); }

const Field& State::field(const std::string& name) const { return *lookup(name); }

Field* State::remembered(const char* name) const {
  const auto a = reinterpret_cast<std::uintptr_t>(name);
  std::atomic<Field*>& slot = by_name_address_[((a >> 3) ^ (a >> 9)) % kNameSlots];
  Field* f = slot.load(std::memory_order_acquire);
  if (f && std::strcmp(f->name().c_str(), name) == 0) return f;
  f = lookup(name);
  slot.store(f, std::memory_order_release);
  return f;
}

Field& State::field(const char* name) { return *remembered(name); }

const Field& State::field(const char* name) const { return *remembered(name); }

std::vector<std::string> State::field_names() const {
  std::vector<std::string> names;
  for (auto& kv : fields_) names.push_back(kv.first);
  return names;
}

}  // namespace ff
