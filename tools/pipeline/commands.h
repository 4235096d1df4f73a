#pragma once
#include <string>
#include <vector>

namespace ff::cli {
int cmd_run(const std::vector<std::string>& args);
int cmd_validate(const std::vector<std::string>& args);
int cmd_graph(const std::vector<std::string>& args);
int cmd_stages(const std::vector<std::string>& args);
int cmd_describe(const std::vector<std::string>& args);
int cmd_bench(const std::vector<std::string>& args);
int cmd_sweep(const std::vector<std::string>& args);
}  // namespace ff::cli
