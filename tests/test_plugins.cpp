// Plugin loading failures are loud and precise.
#include <catch2/catch.hpp>

#include "core/base/error.h"
#include "core/run/plugin_loader.h"
#include "support/test_plugins.h"

using namespace ff;

TEST_CASE("a plugin that is not on the search path is named, with the directories searched", "[plugins]") {
  CHECK_THROWS_WITH(find_plugin("no_such_model", {"/tmp/a", "/tmp/b"}),
                    Catch::Contains("plugin 'no_such_model' not found: no libflipflow_plugin_no_such_model.so") &&
                        Catch::Contains("/tmp/a") && Catch::Contains("/tmp/b"));
  CHECK_THROWS_WITH(find_plugin("/nowhere/libx.so", {}), Catch::Contains("plugin library '/nowhere/libx.so' does not exist"));
}

TEST_CASE("a library without the flipflow exports is refused", "[plugins]") {
  Registry r;
  CHECK_THROWS_WITH(load_plugins({test::test_plugin("no_symbol")}, r),
                    Catch::Contains("is not a flipflow plugin: it does not export flipflow_abi_version"));
}

TEST_CASE("a plugin built for another ABI version is refused", "[plugins]") {
  Registry r;
  CHECK_THROWS_WITH(load_plugins({test::test_plugin("bad_version")}, r),
                    Catch::Contains("was built for flipflow ABI version 999") && Catch::Contains("rebuild the plugin"));
}

TEST_CASE("two plugins declaring one stage are refused, naming both", "[plugins]") {
  Registry r;
  CHECK_THROWS_WITH(load_plugins({test::test_plugin("testing"), test::test_plugin("duplicate")}, r),
                    Catch::Contains("stage 'testing.record' is registered twice") &&
                        Catch::Contains("libflipflow_plugin_testing.so") && Catch::Contains("libflipflow_plugin_duplicate.so"));
}

TEST_CASE("a plugin that registers no stages is refused, naming the library", "[plugins]") {
  Registry r;
  CHECK_THROWS_WITH(load_plugins({test::test_plugin("empty")}, r),
                    Catch::Contains("libflipflow_plugin_empty.so' registers no stages") &&
                        Catch::Contains("FLIPFLOW_STAGE(...)"));
}

TEST_CASE("a file that is not a shared library is refused with the loader's reason", "[plugins]") {
  Registry r;
  CHECK_THROWS_WITH(load_plugins({"/etc/hostname"}, r), Catch::Contains("cannot load plugin '/etc/hostname'"));
}

TEST_CASE("the standard stages and the brownian plugin load; unknown stages and missing backends are named", "[plugins]") {
  auto r = test::registry_with({"brownian"});
  CHECK(r->has("brownian.integrate"));
  CHECK(r->has("core.noop"));
  CHECK(r->get("brownian.integrate").plugin == "libflipflow_plugin_brownian.so");
  CHECK_THROWS_WITH(r->get("brownian.integrat"), Catch::Contains("unknown stage 'brownian.integrat'"));
  Registry bare;
  bare.declare({"x.cpu_only", "", {}, {2}, false});
  bare.implement("x.cpu_only", Backend::cpu, [](const ParamValues&, const RunInfo&) -> std::unique_ptr<Stage> { return nullptr; });
  CHECK_THROWS_WITH(bare.create("x.cpu_only", Backend::cuda, {}, RunInfo{}),
                    Catch::Contains("stage 'x.cpu_only' (plugin '(built in)') has no cuda implementation"));
}
