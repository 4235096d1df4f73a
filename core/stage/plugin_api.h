// Include from a plugin library's top-level plugin.cpp (and nowhere else): exports the ABI
// version and the registration function through Boost.DLL.
//
//   static void register_all(ff::Registry& r) { register_integrate(r); ... }
//   FLIPFLOW_PLUGIN(register_all)
#pragma once
#include <boost/dll/alias.hpp>

#include "core/stage/registry.h"
#include "core/base/version.h"

namespace ff {
using RegisterFunction = void(Registry&);
using AbiVersionFunction = int();
}  // namespace ff

#ifndef FF_PLUGIN_ABI_VERSION
#define FF_PLUGIN_ABI_VERSION FF_ABI_VERSION  // tests override this to build a mismatched plugin
#endif

#define FLIPFLOW_PLUGIN(register_fn)                                               \
  namespace ff_plugin_exports {                                                    \
  inline int abi_version() { return FF_PLUGIN_ABI_VERSION; }                       \
  inline void register_stages(::ff::Registry& r) { register_fn(r); }               \
  }                                                                                \
  BOOST_DLL_ALIAS(ff_plugin_exports::abi_version, flipflow_abi_version)            \
  BOOST_DLL_ALIAS(ff_plugin_exports::register_stages, flipflow_register)
