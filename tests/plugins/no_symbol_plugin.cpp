// A shared library that is not a flipflow plugin (no FLIPFLOW_PLUGIN export).
extern "C" int some_other_function() { return 42; }
