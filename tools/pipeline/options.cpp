#include "tools/pipeline/options.h"

#include <iostream>

#include "core/base/error.h"

namespace po = boost::program_options;

namespace ff::cli {

namespace {

// For "too many positional options": the first word past the pipeline file, and the --set just
// before it when that has no '=' ("--set run.steps 100" meant "--set run.steps=100"). "" if the
// words do not show one.
std::string extra_argument(const std::vector<std::string>& args, const po::options_description& opts) {
  bool file_seen = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a.size() > 1 && a[0] == '-') {
      // An option's value follows it unless given as --name=value.
      const bool inline_value = a.find('=') != std::string::npos;
      const std::string name = a.substr(a.find_first_not_of('-'), a.find('=') - a.find_first_not_of('-'));
      const po::option_description* d = opts.find_nothrow(name, false);
      if (d && !inline_value && d->semantic()->max_tokens() > 0) ++i;
      continue;
    }
    if (!file_seen) {
      file_seen = true;
      continue;
    }
    std::string what = "'" + a + "' is an extra argument";
    if (i >= 2 && args[i - 2] == "--set" && args[i - 1].find('=') == std::string::npos)
      what += "; did you mean --set " + args[i - 1] + "=" + a + "?";
    else
      what += ": the command takes one pipeline file";
    return what;
  }
  return "";
}

}  // namespace

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
  } catch (const po::too_many_positional_options_error& e) {
    const std::string extra = extra_argument(args, opts);
    throw InputError((extra.empty() ? std::string(e.what()) : extra) + " (see pipeline --help)");
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
