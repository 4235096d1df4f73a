#include "tools/pipeline/options.h"

#include <iostream>

#include "core/base/error.h"

namespace po = boost::program_options;

namespace ff::cli {

namespace {

// For "too many positional options": a word that follows a --set without '=' ("--set run.steps
// 100" meant "--set run.steps=100"), else the first word past the pipeline file. "" if the words
// show neither.
std::string extra_argument(const std::vector<std::string>& args, const po::options_description& opts) {
  std::vector<std::size_t> positional;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--") {  // the words after it are all positional
      for (++i; i < args.size(); ++i) positional.push_back(i);
      break;
    }
    const std::size_t name_start = a.find_first_not_of('-');
    if (a.size() > 1 && a[0] == '-' && name_start != std::string::npos) {
      // An option's value follows it unless given as --name=value.
      const bool inline_value = a.find('=') != std::string::npos;
      const std::string name = a.substr(name_start, a.find('=') - name_start);
      const po::option_description* d = opts.find_nothrow(name, false);
      if (d && !inline_value && d->semantic()->max_tokens() > 0) ++i;
      continue;
    }
    positional.push_back(i);
  }
  for (std::size_t i : positional)
    if (i >= 2 && args[i - 2] == "--set" && args[i - 1].find('=') == std::string::npos)
      return "'" + args[i] + "' is an extra argument; did you mean --set " + args[i - 1] + "=" + args[i] + "?";
  if (positional.size() < 2) return "";
  return "'" + args[positional[1]] + "' is an extra argument: the command takes one pipeline file";
}

}  // namespace

po::variables_map parse_options(const std::vector<std::string>& args, po::options_description extra,
                                CommonOptions& common, bool needs_file) {
  // The pipeline file is the positional FILE of the usage line (main.cpp), not listed as --file.
  po::options_description shown("options"), file, opts;
  shown.add_options()("set", po::value<std::vector<std::string>>(&common.overrides)->composing(),
                      "override key.path=value")(
      "device", po::value<std::string>(&common.device)->default_value("auto"), "auto, cpu or cuda");
  shown.add(extra);
  file.add_options()("file", po::value<std::string>(&common.file), "pipeline YAML");
  opts.add(shown).add(file);
  po::positional_options_description pos;
  pos.add("file", 1);
  for (auto& a : args)
    if (a == "--help" || a == "-h") {
      std::cout << shown << "(pipeline --help: every command)\n";
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
