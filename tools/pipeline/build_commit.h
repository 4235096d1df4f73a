#pragma once

// The git commit `pipeline` was built from (`git describe --always --dirty`, as the tree was at
// the last build; "unknown" without git). Recorded by `pipeline run` in its outputs and
// checkpoints and by `pipeline bench` in its JSON lines. Defined in a file the build writes
// (cmake/write_commit.cmake).
const char* flipflow_build_commit();
