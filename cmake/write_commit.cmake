# Writes the source file that tells `pipeline` which commit it was built from.
# Run at every build (tools/CMakeLists.txt, target flipflow_commit), not only when CMake
# configures: a rebuild after `git commit` or `git pull` must not record the older commit.
# The file is rewritten only when the commit changes, so an unchanged tree relinks nothing.
#   cmake -DSOURCE_DIR=<repository> -DOUTPUT=<file.cpp> -P write_commit.cmake
execute_process(COMMAND git -C "${SOURCE_DIR}" describe --always --dirty --abbrev=12
                OUTPUT_VARIABLE commit OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET
                RESULT_VARIABLE status)
if(NOT status EQUAL 0 OR NOT commit)
  set(commit unknown)  # a source tree without git (a tarball, a bundle's sources)
endif()
set(text "// Written by cmake/write_commit.cmake at build time; do not edit.\n#include \"tools/pipeline/build_commit.h\"\n\nconst char* flipflow_build_commit() { return \"${commit}\"; }\n")
if(EXISTS "${OUTPUT}")
  file(READ "${OUTPUT}" old)
endif()
if(NOT old STREQUAL text)
  file(WRITE "${OUTPUT}" "${text}")
endif()
