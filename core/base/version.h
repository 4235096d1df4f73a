#pragma once
// Bumped whenever Stage, StepContext, Registry or State change layout: a plugin built against
// another value is refused at load time instead of crashing.
#define FF_ABI_VERSION 3  // 3: RunInfo::team, Scheduling::team (issue 21)
#define FF_VERSION_STRING "0.1.0"
