# flipflow_add_plugin(NAME <name> SOURCES <cpp...> [CUDA_SOURCES <cu...>] [LIBS <libs...>])
#
# One plugin library = one folder under stages/ or plugins/. The .cu files are compiled only
# when the CUDA backend is on; they see the repository root and Random123, nothing else.
function(flipflow_add_plugin)
  cmake_parse_arguments(P "" "NAME" "SOURCES;CUDA_SOURCES;LIBS" ${ARGN})
  set(target flipflow_${P_NAME})
  set(srcs ${P_SOURCES})
  if(FLIPFLOW_HAVE_CUDA)
    list(APPEND srcs ${P_CUDA_SOURCES})
  endif()
  add_library(${target} MODULE ${srcs})
  target_link_libraries(${target} PRIVATE flipflow_core ${P_LIBS})
  set_target_properties(${target} PROPERTIES
    PREFIX "lib" OUTPUT_NAME "flipflow_${P_NAME}"
    LIBRARY_OUTPUT_DIRECTORY ${FLIPFLOW_PLUGIN_DIR}
    BUILD_RPATH "$ORIGIN/../lib"
    CUDA_SEPARABLE_COMPILATION OFF)
  set_property(GLOBAL APPEND PROPERTY FLIPFLOW_PLUGINS ${target})
endfunction()

# flipflow_cpu_loop_flags(<cpu.cpp> ...)
#
# The hot CPU loops (the overdamped integrators, whose Gaussians for 16 particles at a time are
# drawn in vector lanes, core/overdamped_cpu.h; the Delaunay and overlap edge loops): AVX2
# (x86-64-v3: twice the vector width, and the edge tests' scalar code runs 4-8 % faster), sqrt
# without errno, no trapping FP exceptions. No contraction into fma, so every loop gives the
# same bits as its scalar form and as the CUDA loops (core/rng.h, the delaunay predicates,
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
