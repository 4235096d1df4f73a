#pragma once
// Bumped whenever Stage, StepContext, Registry or State change layout: a plugin built against
// another value is refused at load time instead of crashing.
#define FF_ABI_VERSION 2
#define FF_VERSION_STRING "0.1.0"
