// observe.mean: the mean of a real per-particle field over the particles, or over those of some
// system.types, per component, reported as metrics: observe.h5md writes them under
// /observables/<stage id>/mean (one component) or mean_x, mean_y (, mean_z), with `count`, the
// particles averaged. The mean trap.energy (equipartition: k_BT/2 per trapped axis), the force
// on a probe dragged by trap.harmonic (active microrheology: `types: [probe]`), the pair energy
// per particle, a type's mean Voronoi area.
// An observer: it runs after an accepted step, on the host (on CUDA the core copies the field over
// on the steps it runs: give it `every`). Summed in index order in double: the same value on every
// backend and thread count. A field nothing has computed yet (the initial frame's force: the steps
// compute it) gives NaN, as observe.h5md writes it.
#pragma once
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "core/backend/not_computed.h"
#include "core/base/error.h"
#include "core/base/suggestion.h"
#include "core/stage/params.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "core/stage/state.h"
#include "core/stage/type_names.h"

namespace ff::observe {

struct MeanParams {
  std::string field;
  std::vector<std::string> types{};

  template <class P>
  void describe(P& p) {
    p(field, "field",
      "the real per-particle field to average (trap.energy, force, pair.energy, voronoi.area, ...); its "
      "components are averaged one by one")
        .required();
    p(types, "types", "the names of the system.types whose particles are averaged; [] (the default): all of them");
  }
};

// Per component, the mean of `field` over the particles whose type bit is set in `mask` (all
// when `type` is null), summed in index order in double; `count` the particles taken.
template <class R>
std::vector<double> field_means(const R* value, int components, std::size_t n, const std::int32_t* type,
                                std::uint64_t mask, std::size_t& count) {
  std::vector<double> sum(std::size_t(components), 0.0);
  count = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (type && !((mask >> type[i]) & 1u)) continue;
    ++count;
    for (int c = 0; c < components; ++c) sum[std::size_t(c)] += double(value[i * std::size_t(components) + std::size_t(c)]);
  }
  for (double& s : sum) s = count ? s / double(count) : std::numeric_limits<double>::quiet_NaN();
  return sum;
}

class Mean final : public Stage {
 public:
  static StageDecl declaration() {
    return {"observe.mean",
            "the mean of a real per-particle field (over all particles, or some types), per component, as metrics",
            schema_of<MeanParams>(), {2, 3}, true};
  }

  Mean(const ParamValues& v, const RunInfo& info) : p_(params_from<MeanParams>(v)), id_(info.stage_id) {}

  std::vector<Access> accesses() const override {
    std::vector<Access> a{{p_.field, Where::host, Mode::read}};
    if (!p_.types.empty()) a.push_back({fields::type, Where::host, Mode::read});
    return a;
  }

  void configure(State& s) override {
    const std::string who = "step '" + id_ + "' (observe.mean)";
    if (!s.has_field(p_.field) || !s.is_particle_field(p_.field)) {
      std::vector<std::string> known;
      for (const std::string& name : s.particle_field_names())
        if (is_real(s.field(name).dtype())) known.push_back(name);
      std::string list;
      for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
      throw InputError(who + ": field: there is no per-particle field '" + p_.field + "'" +
                       suggestion(p_.field, known) + " (real per-particle fields here: " + list +
                       "; a field a stage writes exists only when that stage comes before this one in `step:`)");
    }
    if (!is_real(s.field(p_.field).dtype()))
      throw InputError(who + ": field: '" + p_.field + "' holds integers; observe.mean averages real fields");
    mask_ = type_mask(s, p_.types, who);
  }

  Outcome run(StepContext& ctx) override {
    const State& s = ctx.state;
    const Field& f = s.field(p_.field);
    const int components = f.components();
    const std::int32_t* type = p_.types.empty() ? nullptr : s.field(fields::type).host<std::int32_t>();
    std::size_t count = 0;
    std::vector<double> m = s.precision() == Precision::f64
                                ? field_means(f.host<double>(), components, f.count(), type, mask_, count)
                                : field_means(f.host<float>(), components, f.count(), type, mask_, count);
    // Nothing wrote it yet (the initial frame of a field the steps compute): not computed.
    if (not_computed(f)) fill_not_computed(m.data(), DType::f64, m.size());
    static const char* axis[3] = {"x", "y", "z"};
    if (components == 1) ctx.metrics.set("mean", m[0]);
    else
      for (int c = 0; c < components; ++c)
        ctx.metrics.set("mean_" + (c < 3 ? std::string(axis[c]) : std::to_string(c)), m[std::size_t(c)]);
    ctx.metrics.set("count", double(count));
    return Outcome::ok();
  }

 private:
  MeanParams p_;
  std::string id_;
  std::uint64_t mask_ = 0;  // bit t: particles of type t are averaged (with types)
};

}  // namespace ff::observe

FLIPFLOW_HOST_STAGE(ff::observe::Mean)
