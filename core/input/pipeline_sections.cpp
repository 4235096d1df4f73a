// The pipeline file's sections: the top-level keys, system (with its species list and box
// rules), run and plugins. The system and run sections are checked with the same ParamSpec
// machinery as stage parameters, so all sections word their errors the same way.
#include <cstdint>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "core/input/pipeline_yaml.h"

namespace ff::pipeline_detail {

std::vector<Item> top_level(const YAML::Node& root, const Locator& loc) {
  auto items = items_of(root, "", "a map with keys " + join(kTopKeys), loc);
  InputErrorList errors;
  for (auto& item : items)
    if (!one_of(item.key, kTopKeys))
      errors.attempt([&] {
        fail(loc.at(item), item.key,
             "unknown top-level key" + suggestion(item.key, kTopKeys) + " (known keys: " + join(kTopKeys) + ")");
      });
  for (const char* key : {"system", "run", "step"})
    if (!find(items, key))
      errors.attempt([&] { loc.fail(root, "", std::string("missing required top-level key '") + key + "'"); });
  errors.raise();
  return items;
}

namespace {

ParamSpec real_list(std::string name, std::string doc) {
  ParamSpec s;
  s.name = std::move(name);
  s.type = ParamType::real_list;
  s.doc = std::move(doc);
  return s;
}

const std::vector<ParamSpec>& system_schema() {
  static const std::vector<ParamSpec> s = {
      ParamSpec::integer("dimensions", 2, "2 or 3").at_least(2).at_most(3),
      ParamSpec::integer("N", std::nullopt, "number of particles").at_least(1),
      // Also < 1, checked after: ParamSpec bounds are inclusive at the top.
      ParamSpec::real("packing_fraction", std::nullopt, "area/volume fraction; sets the box").above(0),
      real_list("box", "edge lengths, one per dimension").above(0),
      ParamSpec::real("sigma", 1.0, "reference diameter").above(0),
  };
  return s;
}

const ParamSpec& init_placement() {
  static const ParamSpec s = ParamSpec::string("init", "random", "initial positions")
                                 .one_of({"random", "triangular_lattice_sample", "lattice_sample"});
  return s;
}

const std::vector<ParamSpec>& init_from_schema() {
  static const std::vector<ParamSpec> s = {
      ParamSpec::string("from", std::nullopt, "an H5MD file (observe.h5md's output) to start from"),
      ParamSpec::integer("frame", -1, "its frame: 0 the first, -1 the last"),
  };
  return s;
}

const std::vector<ParamSpec>& species_schema() {
  static const std::vector<ParamSpec> s = {
      ParamSpec::string("name", std::nullopt, "species name"),
      ParamSpec::real("fraction", std::nullopt, "share of N (normalised)").above(0),
      ParamSpec::real("diameter", 1.0, "in units of sigma").above(0),
  };
  return s;
}

const std::vector<ParamSpec>& run_schema() {
  static const std::vector<ParamSpec> s = {
      ParamSpec::integer("steps", std::nullopt, "steps to run").at_least(0),
      ParamSpec::real("dt", std::nullopt, "nominal time step").above(0),
      ParamSpec::real("dt_min", std::nullopt, "smallest Δt before giving up (default dt/1024)").above(0),
      ParamSpec::integer("dt_grow_after", 100, "good steps before Δt doubles back").at_least(1),
      ParamSpec::integer("seed", 0, "random seed").at_least(0),
      ParamSpec::string("precision", "double", "real type").one_of({"float", "double"}),
  };
  return s;
}

std::vector<SpeciesSpec> read_types(const YAML::Node& n, const Locator& loc) {
  const std::string path = "system.types";
  const std::string expected = "a non-empty list of maps {name, fraction, diameter}";
  if (!n.IsSequence() || n.size() == 0) loc.fail(n, path, "expected " + expected + ", got " + found(n));
  const Schema schema{species_schema(), {}, {}, "key", known_keys(species_schema(), {})};
  std::vector<SpeciesSpec> types;
  InputErrorList errors;  // every wrong species, not only the first
  for (std::size_t i = 0; i < n.size(); ++i) errors.attempt([&] {
    const std::string at = index(path, i);
    ParamValues v = read_params(n[i], items_of(n[i], at, "a map {name, fraction, diameter}", loc), at, schema, loc);
    for (auto& t : types)
      if (t.name == v.string("name")) loc.fail(n[i], at, "species '" + t.name + "' is listed twice");
    types.push_back(SpeciesSpec{v.string("name"), v.real("fraction"), v.real("diameter")});
  });
  errors.raise();
  return types;
}

// Exactly one of box / packing_fraction sets the box; a box has one edge per dimension.
void check_box(SystemSpec& s, const YAML::Node& map, const std::vector<Item>& items, const Locator& loc) {
  const Item* box = find(items, "box");
  const Item* pf = find(items, "packing_fraction");
  if (box && pf) {
    // Blame an override if one of them is, else the one given second.
    const Location b = loc.at(*box), p = loc.at(*pf);
    const bool box_second = b.line > p.line || (b.line == p.line && b.column > p.column);
    const bool blame_box = b.line == 0 || (p.line != 0 && box_second);
    fail(blame_box ? b : p, "system", "give either 'box' or 'packing_fraction', not both");
  }
  if (!box && !pf && s.init != "from")
    loc.fail(map, "system", "missing 'packing_fraction' or 'box' (one of them sets the box)");
  if (pf && s.packing_fraction >= 1)
    loc.fail(pf->value, "system.packing_fraction", "expected a real number > 0 and < 1, got " + found(pf->value));
  if (box && s.box.size() != std::size_t(s.dimensions))
    loc.fail(box->value, "system.box",
             "expected " + std::to_string(s.dimensions) + " edge lengths (one per dimension; system.dimensions is " +
                 std::to_string(s.dimensions) + "), got " + std::to_string(s.box.size()));
}

// system.init: a placement, or a map {from, frame}.
void read_init(SystemSpec& s, const std::vector<Item>& items, const Locator& loc) {
  if (const Item* init = find(items, "init")) {
    s.where = loc.at(*init);
    if (init->value.IsMap()) {
      const std::string path = "system.init";
      const Schema is{init_from_schema(), {}, {}, "key", known_keys(init_from_schema(), {})};
      ParamValues iv = read_params(init->value, items_of(init->value, path, "a map {from, frame}", loc), path, is, loc);
      s.init = "from";
      s.init_from = iv.string("from");
      s.init_frame = iv.integer("frame");
    } else {
      // A file name where a placement is expected: the user meant to start from that file.
      const std::string word = init->value.IsScalar() ? init->value.Scalar() : "";
      const bool path_like = word.find('/') != std::string::npos ||
                             (word.size() > 3 && word.compare(word.size() - 3, 3, ".h5") == 0);
      if (path_like)
        loc.fail(init->value, "system.init",
                 "expected " + init_placement().expectation() + ", or a map {from, frame}, got " + found(init->value) +
                     "; to start from a file write init: {from: " + word + ", frame: -1}");
      s.init = std::get<std::string>(read_value(init_placement(), init->value, "system.init", loc));
    }
  }
}

}  // namespace

SystemSpec read_system(const YAML::Node& n, const Locator& loc) {
  auto items = items_of(n, "system", "a map of system settings", loc);
  const Schema schema{system_schema(), {"types", "init"}, {"packing_fraction", "box"}, "key",
                      known_keys(system_schema(), {"types", "init"})};
  SystemSpec s;
  s.where = loc.at(n);
  // The keys, init and types are read apart, so that a mistake in each is reported at once;
  // the box rules need all three.
  InputErrorList errors;
  const bool keys_read = errors.attempt([&] {
    ParamValues v = read_params(n, items, "system", schema, loc);
    s.dimensions = int(v.integer("dimensions"));
    s.N = std::uint64_t(v.integer("N"));
    if (v.has("packing_fraction")) s.packing_fraction = v.real("packing_fraction");
    if (v.has("box")) s.box = v.reals("box");
    s.sigma = v.real("sigma");
  });
  const bool init_read = errors.attempt([&] { read_init(s, items, loc); });
  if (const Item* t = find(items, "types")) errors.attempt([&] { s.types = read_types(t->value, loc); });
  if (keys_read && init_read) errors.attempt([&] { check_box(s, n, items, loc); });
  errors.raise();
  return s;
}

const std::vector<ParamSpec>& checkpoint_schema() {
  static const std::vector<ParamSpec> s = {
      ParamSpec::integer("every", 0, "steps between checkpoints (0: only at the end and on SIGINT/SIGTERM)")
          .at_least(0),
      ParamSpec::integer("keep", 2, "newest checkpoint files kept").at_least(1),
  };
  return s;
}

RunSpec read_run(const YAML::Node& n, const Locator& loc) {
  auto items = items_of(n, "run", "a map of run settings", loc);
  const Schema schema{run_schema(), {"checkpoint"}, {"dt_min"}, "key", known_keys(run_schema(), {"checkpoint"})};
  RunSpec r;
  InputErrorList errors;  // the keys and the checkpoint map are reported together
  errors.attempt([&] {
    ParamValues v = read_params(n, items, "run", schema, loc);
    r.steps = std::uint64_t(v.integer("steps"));
    r.dt = v.real("dt");
    r.dt_min = v.has("dt_min") ? v.real("dt_min") : r.dt / 1024;
    if (r.dt_min > r.dt) {
      const YAML::Node& at = find(items, "dt_min")->value;
      loc.fail(at, "run.dt_min",
               "expected a real number > 0 and <= run.dt (" + format_value(r.dt) + "), got " + found(at));
    }
    r.dt_grow_after = std::uint64_t(v.integer("dt_grow_after"));
    r.seed = std::uint64_t(v.integer("seed"));
    r.precision = v.string("precision") == "float" ? Precision::f32 : Precision::f64;
  });
  if (const Item* c = find(items, "checkpoint")) errors.attempt([&] {
    const std::string path = "run.checkpoint";
    const Schema cs{checkpoint_schema(), {}, {}, "key", known_keys(checkpoint_schema(), {})};
    ParamValues cv = read_params(c->value, items_of(c->value, path, "a map {every, keep}", loc), path, cs, loc);
    r.checkpoint = true;
    r.checkpoint_every = std::uint64_t(cv.integer("every"));
    r.checkpoint_keep = std::uint64_t(cv.integer("keep"));
  });
  errors.raise();
  return r;
}

std::vector<std::string> read_plugins(const Item* item, const Locator& loc) {
  if (!item) return {};
  return std::get<std::vector<std::string>>(
      read_value(ParamSpec::strings("plugins", {}, "plugin libraries"), item->value, "plugins", loc));
}

}  // namespace ff::pipeline_detail
