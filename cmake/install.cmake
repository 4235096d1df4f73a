# `cmake --install <build> --prefix <P>`: flipflow as an SDK for model plugins kept outside this
# repository (examples/chiral_abp is one). Included once from the top CMakeLists.txt.
#
#   P/bin/pipeline                        the command
#   P/lib/libflipflow.so                  the core
#   P/lib/flipflow/plugins/*.so           the standard stages and the model plugins (the installed
#                                         pipeline looks there: core/run/plugin_loader.cpp)
#   P/include/core/**.h, *.cuh            every header a plugin may include (same include paths)
#   P/include/stages/neighbors/           pair_force.h (neighbors::PairForceStage, a pair force
#                                         over the Verlet list) and list.h (the list's fields):
#                                         "stages/neighbors/pair_force.h" as in the repository
#   P/include/flipflow/tests/support/     the test-support headers a test beside a stage includes
#                                         as "support/stage_driver.h" in and out of the repository
#                                         (stage_driver.h, test_plugins.h, backends.h, fields.h,
#                                         spec.h); on the include path of the tests
#                                         flipflow_add_plugin builds, not of flipflow::core, so
#                                         that `support/` names nothing in P/include itself
#   P/share/flipflow/sdk/plugin_entry.cpp compiled into every plugin (flipflow_add_plugin)
#   P/lib/cmake/flipflow/                 find_package(flipflow): flipflowConfig.cmake (the
#                                         imported target flipflow::core, the settings of this
#                                         build, flipflow_add_plugin), its version file and
#                                         flipflow_plugin.cmake
#
# Only flipflow itself is installed: TBB, Boost, yaml-cpp, HDF5, CGAL and Random123 stay where
# the system has them (the package records where Random123 was). Install paths are fixed (not
# GNUInstallDirs' lib64 or lib/<multiarch>) because the plugin loader looks for
# <exe dir>/../lib/flipflow/plugins.
include(CMakePackageConfigHelpers)

set(FLIPFLOW_INSTALL_PLUGIN_DIR lib/flipflow/plugins)
set(FLIPFLOW_INSTALL_CMAKE_DIR lib/cmake/flipflow)

install(DIRECTORY ${PROJECT_SOURCE_DIR}/core/ DESTINATION include/core
        FILES_MATCHING PATTERN "*.h" PATTERN "*.cuh")
install(FILES ${PROJECT_SOURCE_DIR}/core/sdk/plugin_entry.cpp DESTINATION share/flipflow/sdk)
# Only headers that include nothing but core/ and each other (test_sdk_example checks that every
# quoted include of an installed header resolves inside the install).
install(FILES ${PROJECT_SOURCE_DIR}/stages/neighbors/pair_force.h ${PROJECT_SOURCE_DIR}/stages/neighbors/list.h
        DESTINATION include/stages/neighbors)
install(FILES ${PROJECT_SOURCE_DIR}/tests/support/stage_driver.h ${PROJECT_SOURCE_DIR}/tests/support/test_plugins.h
              ${PROJECT_SOURCE_DIR}/tests/support/backends.h ${PROJECT_SOURCE_DIR}/tests/support/fields.h
              ${PROJECT_SOURCE_DIR}/tests/support/spec.h ${PROJECT_SOURCE_DIR}/tests/support/temp_dir.h
        DESTINATION include/flipflow/tests/support)

configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/flipflowConfig.cmake.in
  ${PROJECT_BINARY_DIR}/package/flipflowConfig.cmake
  INSTALL_DESTINATION ${FLIPFLOW_INSTALL_CMAKE_DIR})
# 0.x: a plugin needs the same minor version (the ABI number, core/base/version.h, is checked again
# when the plugin is loaded).
write_basic_package_version_file(${PROJECT_BINARY_DIR}/package/flipflowConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/package/flipflowConfig.cmake
              ${PROJECT_BINARY_DIR}/package/flipflowConfigVersion.cmake
              ${PROJECT_SOURCE_DIR}/cmake/flipflow_plugin.cmake
        DESTINATION ${FLIPFLOW_INSTALL_CMAKE_DIR})

# The binaries, once every directory has declared its plugins (deferred to the end of the top
# directory, so this file may be included anywhere in it). Installed rpaths: the core next to
# the command and the plugins; directories of non-system libraries they link (CUDA's runtime)
# are kept.
function(flipflow_install_binaries)
  get_property(plugins GLOBAL PROPERTY FLIPFLOW_PLUGINS)
  file(RELATIVE_PATH plugin_to_lib /p/${FLIPFLOW_INSTALL_PLUGIN_DIR} /p/lib)
  set_target_properties(flipflow_core PROPERTIES INSTALL_RPATH_USE_LINK_PATH ON)
  set_target_properties(pipeline PROPERTIES INSTALL_RPATH "$ORIGIN/../lib" INSTALL_RPATH_USE_LINK_PATH ON)
  set_target_properties(${plugins} PROPERTIES
    INSTALL_RPATH "$ORIGIN/${plugin_to_lib}" INSTALL_RPATH_USE_LINK_PATH ON)
  install(TARGETS flipflow_core LIBRARY DESTINATION lib)
  install(TARGETS pipeline RUNTIME DESTINATION bin)
  install(TARGETS ${plugins} LIBRARY DESTINATION ${FLIPFLOW_INSTALL_PLUGIN_DIR})
endfunction()
cmake_language(DEFER DIRECTORY ${PROJECT_SOURCE_DIR} CALL flipflow_install_binaries)
