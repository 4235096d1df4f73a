// Command-line options shared by the subcommands (Boost.Program_options).
#pragma once
#include <boost/program_options.hpp>
#include <string>
#include <vector>

namespace ff::cli {

struct CommonOptions {
  std::string file;
  std::vector<std::string> overrides;  // --set
  std::string device = "auto";
};

// Thrown by parse_options after printing a command's options for --help: `pipeline` exits 0.
struct HelpShown {};

// Parses `args` with the given extra options plus FILE/--set/--device; InputError on bad flags;
// with --help (-h), prints the options and throws HelpShown.
boost::program_options::variables_map parse_options(const std::vector<std::string>& args,
                                                    boost::program_options::options_description extra,
                                                    CommonOptions& common, bool needs_file = true);

}  // namespace ff::cli
