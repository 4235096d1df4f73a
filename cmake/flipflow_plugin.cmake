# flipflow_add_plugin(NAME <name> [SOURCES <cpp...>] [CUDA_SOURCES <cu...>] [LIBS <libs...>]
#                     [EXCLUDE <files of the folder not to compile into it, nor as a test>])
#
# One plugin library = one folder (stages/<lib>, plugins/<model>, or a model's own folder
# outside this repository). Without SOURCES the folder is read by convention, so a new stage
# is its folder and nothing else:
#   - every stage.h below the folder that registers a stage (FLIPFLOW_STAGE or
#     FLIPFLOW_HOST_STAGE, core/stage/stage_registration.h) is compiled once per backend, from a
#     generated source that sets FLIPFLOW_STAGE_EXEC (CpuExec, and CudaExec when
#     FLIPFLOW_PLUGIN_CUDA is on: in this repository whenever CUDA is, against an install unless
#     the project turns it off, flipflowConfig.cmake);
#   - every other .cpp below it (not test_*.cpp) and, with CUDA on, every .cu is compiled too (the
#     loops a stage writes by hand);
#   - the library's entry point (core/sdk/plugin_entry.cpp) registers what they declare;
#   - every test_<name>.cpp below it is a test beside its stage, the CTest test and executable
#     test_<folder>_<name>, or test_<folder> when <name> is the folder's own name
#     (stages/overlap_correct/test_overlap_correct.cpp), linked with the core and Catch2 and built
#     after every plugin. It includes the test-support headers as "support/stage_driver.h",
#     "support/test_plugins.h", ... (tests/support). In this repository tests/CMakeLists.txt builds
#     them; built against an installed flipflow (FLIPFLOW_SDK, flipflowConfig.cmake) this function
#     has them built at the end of the directory that found the package
#     (flipflow_sdk_add_stage_tests), with the installed support headers and Catch2's own main;
#     without Catch2 2.x it names the tests it leaves out in a CMake warning. What one of them
#     links besides: flipflow_stage_test_libs below.
# With SOURCES (libraries not yet in this shape) exactly those files are compiled and one of them
# defines the entry point (FLIPFLOW_PLUGIN). The .cu files see the repository root and
# Random123, nothing else.
function(flipflow_add_plugin)
  cmake_parse_arguments(P "" "NAME" "SOURCES;CUDA_SOURCES;LIBS;EXCLUDE" ${ARGN})
  set(target flipflow_${P_NAME})
  set(srcs ${P_SOURCES})
  if(FLIPFLOW_PLUGIN_CUDA)
    list(APPEND srcs ${P_CUDA_SOURCES})
  endif()
  if(NOT P_SOURCES)
    flipflow_plugin_sources(srcs)
    foreach(x ${P_EXCLUDE})  # files of the folder built elsewhere (relative paths)
      list(REMOVE_ITEM srcs ${CMAKE_CURRENT_SOURCE_DIR}/${x})
    endforeach()
  endif()
  # No contracted multiply-adds on the device: the CUDA loops then round exactly as the CPU
  # loops (built with -ffp-contract=off) do, so CPU and CUDA runs give the same bits. A
  # compute-bound kernel may set -fmad=true on its own file (and give up that promise).
  set(cu_srcs ${srcs})
  list(FILTER cu_srcs INCLUDE REGEX "\\.cu$")
  if(cu_srcs)
    set_source_files_properties(${cu_srcs} PROPERTIES COMPILE_OPTIONS "-fmad=false")
  endif()
  add_library(${target} MODULE ${srcs})
  target_link_libraries(${target} PRIVATE ${FLIPFLOW_CORE_TARGET} ${P_LIBS})
  set_target_properties(${target} PROPERTIES
    PREFIX "lib" OUTPUT_NAME "flipflow_${P_NAME}"
    LIBRARY_OUTPUT_DIRECTORY ${FLIPFLOW_PLUGIN_DIR}
    BUILD_RPATH "$ORIGIN/../lib"
    CUDA_SEPARABLE_COMPILATION OFF)
  set_property(GLOBAL APPEND PROPERTY FLIPFLOW_PLUGINS ${target})
  # Tests beside the stages (test_*.cpp below the folder), each test_<folder>_<name>, or
  # test_<folder> for test_<folder>.cpp: collected here, built once every plugin is declared (by
  # tests/CMakeLists.txt in this repository, by flipflow_sdk_add_stage_tests against an install).
  file(GLOB_RECURSE tests CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/test_*.cpp)
  get_filename_component(folder ${CMAKE_CURRENT_SOURCE_DIR} NAME)
  foreach(x ${P_EXCLUDE})  # a test_*.cpp the project builds itself (a program of its own)
    list(REMOVE_ITEM tests ${CMAKE_CURRENT_SOURCE_DIR}/${x})
  endforeach()
  foreach(t ${tests})
    string(FIND "${t}" "${CMAKE_BINARY_DIR}/" at)
    if(at EQUAL 0)  # as in flipflow_plugin_sources: never a file of a build tree inside the folder
      list(REMOVE_ITEM tests ${t})
      continue()
    endif()
    get_filename_component(stem ${t} NAME_WE)
    string(REGEX REPLACE "^test_" "" stem "${stem}")
    if(stem STREQUAL folder)
      set(name test_${folder})
    else()
      set(name test_${folder}_${stem})
    endif()
    set_property(GLOBAL APPEND PROPERTY FLIPFLOW_STAGE_TESTS "${name}|${t}")
  endforeach()
  get_property(scheduled GLOBAL PROPERTY FLIPFLOW_SDK_STAGE_TESTS_SCHEDULED)
  if(tests AND FLIPFLOW_SDK AND NOT scheduled)
    set_property(GLOBAL PROPERTY FLIPFLOW_SDK_STAGE_TESTS_SCHEDULED ON)
    # At the end of the directory that found the package (this one or one above it), once every
    # plugin below it is declared: its variables and flipflow::core are visible there.
    # enable_testing() there too, not in the function (where it would set its variable in the
    # function's scope only), so that `ctest --test-dir <build>` finds the tests unasked.
    cmake_language(DEFER DIRECTORY ${FLIPFLOW_FIND_PACKAGE_DIR} CALL flipflow_sdk_add_stage_tests)
    cmake_language(DEFER DIRECTORY ${FLIPFLOW_FIND_PACKAGE_DIR} CALL enable_testing)
  endif()
endfunction()

# flipflow_sdk_add_stage_tests()
#
# The tests beside the stages of a project built against an installed flipflow, as
# tests/CMakeLists.txt builds them in this repository: one executable and CTest test per
# test_*.cpp, linked with flipflow::core, Catch2 (with Catch2's main) and its
# flipflow_stage_test_libs, including the installed test-support headers as "support/..."
# (FLIPFLOW_TEST_INCLUDE_DIR), built after every plugin of the project. The test finds the
# project's plugins and the install's standard stages through FLIPFLOW_STAGE_TEST_PLUGIN_PATH
# (support/test_plugins.h), compiled in, so `ctest` and the executable run alone load the same
# libraries. Called once, deferred by flipflow_add_plugin to the end of the directory that called
# find_package(flipflow).
function(flipflow_sdk_add_stage_tests)
  get_property(entries GLOBAL PROPERTY FLIPFLOW_STAGE_TESTS)
  # The support headers include <catch2/catch.hpp>: Catch2 2.x (Debian 12: catch2), not 3.
  find_package(Catch2 2 QUIET)
  if(NOT TARGET Catch2::Catch2WithMain)
    set(files)
    foreach(entry ${entries})
      string(REPLACE "|" ";" entry "${entry}")
      list(GET entry 1 file)
      list(APPEND files ${file})
    endforeach()
    list(JOIN files "\n  " files)
    message(WARNING "flipflow: Catch2 2.x (with its Catch2::Catch2WithMain; Debian: apt install catch2) "
                    "was not found, so these tests beside the stages are not built and ctest will not run "
                    "them:\n  ${files}\nInstall it (or point Catch2_DIR at it) and configure again.")
    return()
  endif()
  get_property(plugins GLOBAL PROPERTY FLIPFLOW_PLUGINS)
  set(plugin_path)
  foreach(p ${plugins})
    list(APPEND plugin_path "$<TARGET_FILE_DIR:${p}>")
  endforeach()
  list(APPEND plugin_path "${FLIPFLOW_INSTALLED_PLUGIN_DIR}")
  list(JOIN plugin_path ":" plugin_path)
  foreach(entry ${entries})
    string(REPLACE "|" ";" entry "${entry}")
    list(GET entry 0 name)
    list(GET entry 1 file)
    get_property(libs GLOBAL PROPERTY "FLIPFLOW_STAGE_TEST_LIBS:${file}")
    add_executable(${name} ${file})
    target_link_libraries(${name} PRIVATE ${FLIPFLOW_CORE_TARGET} Catch2::Catch2WithMain ${libs})
    target_include_directories(${name} PRIVATE ${FLIPFLOW_TEST_INCLUDE_DIR})
    target_compile_definitions(${name} PRIVATE "FLIPFLOW_STAGE_TEST_PLUGIN_PATH=\"${plugin_path}\"")
    if(FLIPFLOW_HAVE_CUDA AND NOT FLIPFLOW_PLUGIN_CUDA)  # the plugins have no CUDA stages to test
      target_compile_definitions(${name} PRIVATE FLIPFLOW_STAGE_TEST_CPU_ONLY)
    endif()
    add_dependencies(${name} ${plugins})
    add_test(NAME ${name} COMMAND ${name})
  endforeach()
endfunction()

# flipflow_stage_test_libs(<test_*.cpp, relative to the folder> <libs...>)
#
# What one test beside the stages links besides the core and Catch2: CGAL for the test that
# compares with CGAL's triangulation, an interface library of a stage's sources for a test that
# drives the stage's classes directly. Call from the plugin's CMakeLists.txt.
function(flipflow_stage_test_libs test)
  get_filename_component(file ${test} ABSOLUTE BASE_DIR ${CMAKE_CURRENT_SOURCE_DIR})
  if(NOT EXISTS ${file})
    message(FATAL_ERROR "flipflow_stage_test_libs: no test ${file}")
  endif()
  set_property(GLOBAL APPEND PROPERTY "FLIPFLOW_STAGE_TEST_LIBS:${file}" ${ARGN})
endfunction()

# The sources of a plugin folder read by convention (see flipflow_add_plugin).
function(flipflow_plugin_sources out)
  set(srcs ${FLIPFLOW_PLUGIN_ENTRY})
  file(GLOB_RECURSE headers CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/stage.h
       ${CMAKE_CURRENT_SOURCE_DIR}/*/stage.h)
  list(REMOVE_DUPLICATES headers)
  foreach(h ${headers})
    file(READ ${h} text)
    file(RELATIVE_PATH rel ${CMAKE_CURRENT_SOURCE_DIR} ${h})
    string(REGEX REPLACE "[/.]" "_" stem "${rel}")
    set(gen ${CMAKE_CURRENT_BINARY_DIR}/generated/${stem})
    # The registration line may be indented; a stage.h without one would be left out of the
    # plugin without a word, and the loader would then find the plugin empty.
    if(NOT text MATCHES "\n[ \t]*FLIPFLOW_(HOST_)?STAGE[(]")
      message(FATAL_ERROR "${h}: no line starts with FLIPFLOW_STAGE(...) or FLIPFLOW_HOST_STAGE(...), "
                          "so this stage is not compiled into the plugin (docs/writing-a-model.md)")
    endif()
    # Every stage has a CPU build; a FLIPFLOW_STAGE (not a host stage) a CUDA one too.
    file(CONFIGURE OUTPUT ${gen}_cpu.cpp CONTENT
"// Generated by flipflow_add_plugin: the CPU build of ${rel}.
#define FLIPFLOW_STAGE_EXEC ::ff::CpuExec
#include \"core/backend/exec_cpu.h\"
#include \"${h}\"
")
    list(APPEND srcs ${gen}_cpu.cpp)
    flipflow_cpu_loop_flags(${gen}_cpu.cpp)
    if(FLIPFLOW_PLUGIN_CUDA AND text MATCHES "\n[ \t]*FLIPFLOW_STAGE[(]")
      file(CONFIGURE OUTPUT ${gen}_cuda.cu CONTENT
"// Generated by flipflow_add_plugin: the CUDA build of ${rel}.
#define FLIPFLOW_STAGE_EXEC ::ff::CudaExec
#include \"core/backend/cuda/loop.cuh\"
#include \"${h}\"
")
      list(APPEND srcs ${gen}_cuda.cu)
    endif()
  endforeach()
  file(GLOB_RECURSE cpp CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*.cpp)
  list(FILTER cpp EXCLUDE REGEX "/test_[^/]*\\.cpp$")
  if(FLIPFLOW_PLUGIN_CUDA)
    file(GLOB_RECURSE cu CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*.cu)
    list(APPEND cpp ${cu})
  endif()
  # Never the build tree's own files (the generated sources above, CMake's compiler checks) when
  # it lies inside the folder: a plugin outside the repository built in <folder>/build.
  foreach(f ${cpp})
    string(FIND "${f}" "${CMAKE_BINARY_DIR}/" at)
    if(NOT at EQUAL 0)
      list(APPEND srcs ${f})
    endif()
  endforeach()
  set(${out} ${srcs} PARENT_SCOPE)
endfunction()

# flipflow_cpu_loop_flags(<cpu.cpp> ...)
#
# The hot CPU loops (the overdamped integrators, whose Gaussians for 16 particles at a time are
# drawn in vector lanes, core/backend/overdamped_cpu.h; the Delaunay and overlap edge loops): AVX2
# (x86-64-v3: twice the vector width, and the edge tests' scalar code runs 4-8 % faster), sqrt
# without errno, no trapping FP exceptions. No contraction into fma, so every loop gives the
# same bits as its scalar form and as the CUDA loops (core/physics/rng.h, the delaunay predicates,
# overlap_correct's fixed-point pushes); values are otherwise unchanged. Call from the plugin's
# CMakeLists.txt. A CPU without AVX2 cannot run these files: the plugin loader says so instead
# of letting them fault; configure with -DFLIPFLOW_X86_64_V3=OFF for such a CPU.
function(flipflow_cpu_loop_flags)
  if(FLIPFLOW_X86_64_V3)
    set_source_files_properties(${ARGN} PROPERTIES COMPILE_OPTIONS
      "-march=x86-64-v3;-ffp-contract=off;-fno-math-errno;-fno-trapping-math")
  else()
    set_source_files_properties(${ARGN} PROPERTIES COMPILE_OPTIONS
      "-ffp-contract=off;-fno-math-errno")
  endif()
endfunction()
