// One registration path for every stage. A stage is a class template S<R> (R = float or
// double) in its folder's stage.h that provides
//
//   static StageDecl declaration();                 // name, summary, parameters, dimensions
//   template <class Exec>                           // CpuExec (core/backend/exec_cpu.h) or CudaExec
//   S(const ParamValues&, const RunInfo&, Exec);    // (core/backend/cuda/loop.cuh)
//
// and ends with FLIPFLOW_STAGE(S). The plugin's build (cmake/flipflow_plugin.cmake) compiles
// the stage.h once per backend with FLIPFLOW_STAGE_EXEC set to that backend's Exec, so the
// constructor instantiates its element loops (Exec::for_each, Exec::overdamped) there; each
// compilation adds one backend of the stage to the library's list, and the library's entry point
// (core/sdk/plugin_entry.cpp, compiled into every plugin) registers the list. A host-only stage
// (an observer reading host fields) is one class S whose constructor takes
// (const ParamValues&, const RunInfo&) and ends its stage.h with FLIPFLOW_HOST_STAGE(S): the
// same implementation serves every backend. An alias (an old name for a configuration of
// another stage) is add_alias from any .cpp of the library; param_values, which builds the
// ParamValues it takes, is in core/stage/params.h (included here through registry.h). nvcc-clean.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "core/stage/registry.h"

namespace ff {

// One entry of a plugin library's list: a backend of a stage, or an alias.
struct PluginStage {
  StageDecl decl;
  Backend backend = Backend::cpu;
  StageFactory factory;          // null for an alias
  std::string alias_of;          // for an alias: the stage it configures
  ParamValues fixed;             // for an alias: the parameters it sets
  ParamValues defaults;          // for an alias: defaults it changes (still settable)
};

// The list of the library being loaded: one per shared library (hidden, never shared between
// plugins), defined by core/sdk/plugin_entry.cpp.
__attribute__((visibility("hidden"))) std::vector<PluginStage>& plugin_stages();

template <template <class> class S, class Exec>
bool add_stage() {
  plugin_stages().push_back(
      {S<double>::declaration(), Exec::backend,
       [](const ParamValues& v, const RunInfo& info) -> std::unique_ptr<Stage> {
         if (info.precision == Precision::f32) return std::make_unique<S<float>>(v, info, Exec{});
         return std::make_unique<S<double>>(v, info, Exec{});
       },
       {}, {}, {}});
  return true;
}

template <class S>
bool add_host_stage() {
  auto make = [](const ParamValues& v, const RunInfo& info) -> std::unique_ptr<Stage> {
    return std::make_unique<S>(v, info);
  };
  plugin_stages().push_back({S::declaration(), Backend::cpu, make, {}, {}, {}});
#ifdef FLIPFLOW_HAVE_CUDA
  plugin_stages().push_back({S::declaration(), Backend::cuda, make, {}, {}, {}});
#endif
  return true;
}

// An alias: `name` runs the stage `target` (registered by a library loaded earlier, such as the
// standard stages) with the parameters in `fixed` set and the defaults in `defaults` changed.
// From one .cpp of the plugin:
//   [[maybe_unused]] static const bool registered = ff::add_alias("brownian.integrate",
//       "overdamped.integrate", "free Brownian motion", ff::param_values({{"drift", std::string("none")}}));
inline bool add_alias(std::string name, std::string target, std::string summary, ParamValues fixed,
                      ParamValues defaults = {}) {
  StageDecl d;
  d.name = std::move(name);
  d.summary = std::move(summary);
  plugin_stages().push_back(
      {std::move(d), Backend::cpu, nullptr, std::move(target), std::move(fixed), std::move(defaults)});
  return true;
}

}  // namespace ff

#define FLIPFLOW_CONCAT_(a, b) a##b
#define FLIPFLOW_CONCAT(a, b) FLIPFLOW_CONCAT_(a, b)

// Registers a stage template for the backend its stage.h is being compiled for (nothing when the
// header is included elsewhere, e.g. by a test).
#ifdef FLIPFLOW_STAGE_EXEC
#define FLIPFLOW_STAGE(...)                                                     \
  namespace {                                                                   \
  [[maybe_unused]] const bool FLIPFLOW_CONCAT(flipflow_stage_, __LINE__) =      \
      ::ff::add_stage<__VA_ARGS__, FLIPFLOW_STAGE_EXEC>();                      \
  }
#else
#define FLIPFLOW_STAGE(...)
#endif

// Registers a host-only stage class for every backend (from the host compilation only).
#if defined(FLIPFLOW_STAGE_EXEC) && !defined(__CUDACC__)
#define FLIPFLOW_HOST_STAGE(...)                                                \
  namespace {                                                                   \
  [[maybe_unused]] const bool FLIPFLOW_CONCAT(flipflow_stage_, __LINE__) =      \
      ::ff::add_host_stage<__VA_ARGS__>();                                      \
  }
#else
#define FLIPFLOW_HOST_STAGE(...)
#endif
