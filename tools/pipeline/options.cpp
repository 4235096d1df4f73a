#include "tools/pipeline/options.h"

#include <iostream>

#include "core/base/error.h"

namespace po = boost::program_options;

namespace ff::cli {

po::variables_map parse_options(const std::vector<std::string>& args, po::options_description extra,
                                CommonOptions& common, bool needs_file) {
  po::options_description opts("options");
  opts.add_options()("file", po::value<std::string>(&common.file), "pipeline YAML")(
      "set", po::value<std::vector<std::string>>(&common.overrides)->composing(), "override key.path=value")(
      "device", po::value<std::string>(&common.device)->default_value("auto"), "auto, cpu or cuda");
  opts.add(extra);
  po::positional_options_description pos;
  pos.add("file", 1);
  for (auto& a : args)
    if (a == "--help" || a == "-h") {
      std::cout << opts << "(pipeline --help: every command)\n";
      throw HelpShown{};
    }
  po::variables_map vm;
  try {
    po::store(po::command_line_parser(args).options(opts).positional(pos).run(), vm);
    po::notify(vm);
  } catch (const po::error& e) {
    throw InputError(std::string(e.what()) + " (see pipeline --help)");
  }
  if (needs_file && common.file.empty()) throw InputError("missing the pipeline file (see pipeline --help)");
  // Spelled right for every command, validate and graph included (which do not pick a device).
  if (common.device != "auto" && common.device != "cpu" && common.device != "cuda")
    throw InputError("--device must be auto, cpu or cuda (got '" + common.device + "')");
  if (vm.count("out") && vm["out"].as<std::string>().empty())
    throw InputError("--out: empty (give a folder, or leave --out out for the default)");
  return vm;
}

}  // namespace ff::cli
