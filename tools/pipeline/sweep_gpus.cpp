// `pipeline sweep`: which GPUs, and a CUDA MPS control daemon for runs that share one (sweep.h).
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "core/backend/device.h"
#include "core/base/error.h"
#include "tools/pipeline/sweep.h"

extern char** environ;

namespace fs = std::filesystem;

namespace ff::cli::sweep {

namespace {
std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, sep);)
    if (!item.empty()) out.push_back(item);
  return out;
}

std::string find_on_path(const std::string& program) {
  const char* path = std::getenv("PATH");
  std::vector<std::string> dirs = split(path ? path : "", ':');
  dirs.push_back("/usr/bin");
  dirs.push_back("/usr/local/bin");
  for (auto& d : dirs) {
    const fs::path p = fs::path(d) / program;
    if (::access(p.c_str(), X_OK) == 0) return p.string();
  }
  return "";
}

// Runs `program args` with `env` added to ours (less CUDA_VISIBLE_DEVICES: the daemon sees every
// GPU, so a run's CUDA_VISIBLE_DEVICES means the same with MPS as without), stdin from `input`,
// stdout and stderr to `log`, and waits; its exit status, -1 if it did not exit.
int run_helper(const std::string& program, const std::vector<std::string>& args, const std::vector<std::string>& env,
               const std::string& input, const std::string& log) {
  int fds[2];
  if (::pipe(fds) != 0) return -1;
  std::vector<std::string> envs;
  for (char** e = environ; *e; ++e)
    if (std::string(*e).rfind("CUDA_VISIBLE_DEVICES=", 0) != 0) envs.push_back(*e);
  for (auto& e : env) envs.push_back(e);
  std::vector<char*> envp, argv;
  for (auto& e : envs) envp.push_back(const_cast<char*>(e.c_str()));
  envp.push_back(nullptr);
  argv.push_back(const_cast<char*>(program.c_str()));
  for (auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::dup2(fds[0], 0);
    ::close(fds[1]);
    const int out = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    if (out >= 0) {
      ::dup2(out, 1);
      ::dup2(out, 2);
    }
    ::execve(program.c_str(), argv.data(), envp.data());
    ::_exit(127);
  }
  ::close(fds[0]);
  if (pid > 0 && !input.empty()) (void)!::write(fds[1], input.data(), input.size());
  ::close(fds[1]);
  int status = 0;
  if (pid < 0 || ::waitpid(pid, &status, 0) != pid) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string file_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}
}  // namespace

std::vector<std::string> visible_gpus(const std::string& gpus_arg) {
  std::error_code ec;
  std::size_t n = 0;  // the machine's GPUs, as the driver lists them (0 where it cannot tell)
  for (auto it = fs::directory_iterator("/proc/driver/nvidia/gpus", ec); !ec && it != fs::directory_iterator(); ++it)
    ++n;
  if (!gpus_arg.empty()) {
    // Each a CUDA_VISIBLE_DEVICES entry of a child: an index of the machine's GPUs, or a UUID.
    // Checked here, before any folder is made, not found by every run failing at its start.
    const std::vector<std::string> gpus = split(gpus_arg, ',');
    if (gpus.empty()) throw InputError("--gpus '" + gpus_arg + "': no GPU listed (e.g. --gpus 0,1)");
    for (std::size_t i = 0; i < gpus.size(); ++i) {
      const std::string& g = gpus[i];
      const bool index = !g.empty() && g.size() <= 4 && g.find_first_not_of("0123456789") == std::string::npos;
      const bool uuid = g.rfind("GPU-", 0) == 0 || g.rfind("MIG-", 0) == 0;
      if (!index && !uuid)
        throw InputError("--gpus " + gpus_arg + ": '" + g + "' is not a GPU (an index, 0 to " +
                         (n ? std::to_string(n - 1) : std::string("N - 1")) + ", or a GPU-/MIG- UUID)");
      if (index && n && std::size_t(std::stoi(g)) >= n)
        throw InputError("--gpus " + gpus_arg + ": GPU " + g + " does not exist (this machine has " + std::to_string(n) +
                         ": 0 to " + std::to_string(n - 1) + ")");
      for (std::size_t j = 0; j < i; ++j)
        if (gpus[j] == g)
          throw InputError("--gpus " + gpus_arg + ": GPU " + g + " is listed twice (for more runs at once on a GPU, "
                           "use --concurrent K)");
    }
    return gpus;
  }
  if (const char* v = std::getenv("CUDA_VISIBLE_DEVICES"))
    if (!split(v, ',').empty()) return split(v, ',');
  std::vector<std::string> out;
  for (std::size_t i = 0; i < std::max<std::size_t>(n, 1); ++i) out.push_back(std::to_string(i));
  return out;
}

std::vector<std::string> process_gpus(const std::string& gpus_arg) {
  const int count = cuda_device_count();
  std::vector<std::string> out;
  if (gpus_arg.empty()) {
    for (int d = 0; d < std::max(count, 1); ++d) out.push_back(std::to_string(d));
    return out;
  }
  for (const std::string& g : split(gpus_arg, ',')) {
    const bool digits = !g.empty() && g.find_first_not_of("0123456789") == std::string::npos;
    if (!digits || g.size() > 4 || std::stoi(g) >= count)
      throw InputError("--gpus " + gpus_arg + " with --in-process: '" + g + "' is not a CUDA device of this process (0 to " +
                       std::to_string(count - 1) + "; CUDA_VISIBLE_DEVICES numbers them from 0)");
    const std::string d = std::to_string(std::stoi(g));
    if (std::find(out.begin(), out.end(), d) != out.end())
      throw InputError("--gpus " + gpus_arg + " with --in-process: GPU " + d +
                       " is listed twice (for more runs at once on a GPU, use --concurrent K)");
    out.push_back(d);
  }
  return out;
}

Mps::Mps(const std::string& mode, bool wanted, std::string& note) {
  if (mode == "off" || !wanted) return;
  const char* pipe_env = std::getenv("CUDA_MPS_PIPE_DIRECTORY");
  const std::string pipe_dir = pipe_env && *pipe_env ? pipe_env : "/tmp/nvidia-mps";
  if (fs::exists(fs::path(pipe_dir) / "control")) {
    active_ = true;
    note = "CUDA MPS: using the control daemon of " + pipe_dir;
    return;
  }
  control_ = find_on_path("nvidia-cuda-mps-control");
  if (control_.empty()) {
    if (mode == "on")
      throw InputError("--mps on: no MPS control daemon is running and nvidia-cuda-mps-control is not on PATH");
    note = "no CUDA MPS (nvidia-cuda-mps-control not found): the runs sharing a GPU time-slice it";
    return;
  }
  char tmpl[] = "/tmp/flipflow-mps-XXXXXX";  // short: the pipe is a Unix socket path (108 bytes at most)
  if (!::mkdtemp(tmpl)) throw RunError("cannot create a directory for the MPS daemon in /tmp");
  dir_ = tmpl;
  const fs::path dir(dir_);
  fs::create_directories(dir / "pipe");
  fs::create_directories(dir / "log");
  env_ = {"CUDA_MPS_PIPE_DIRECTORY=" + (dir / "pipe").string(), "CUDA_MPS_LOG_DIRECTORY=" + (dir / "log").string()};
  const int rc = run_helper(control_, {"-d"}, env_, "", (dir / "log" / "start.log").string());
  if (rc != 0) {
    const std::string why = file_text(dir / "log" / "start.log");
    std::error_code ec;
    fs::remove_all(dir, ec);
    env_.clear();
    if (mode == "on")
      throw InputError("--mps on: nvidia-cuda-mps-control -d failed (exit " + std::to_string(rc) + "): " + why);
    note = "CUDA MPS could not be started (nvidia-cuda-mps-control -d: exit " + std::to_string(rc) +
           "): the runs sharing a GPU time-slice it";
    return;
  }
  active_ = owned_ = true;
  note = "CUDA MPS: started a control daemon (pipe directory " + (dir / "pipe").string() + "), stopped at the end";
}

Mps::~Mps() {
  if (!owned_) return;
  const fs::path dir(dir_);
  run_helper(control_, {}, env_, "quit\n", (dir / "log" / "stop.log").string());
  // The daemon removes its pipe on quit; give it a moment before the folder goes.
  for (int i = 0; i < 50 && fs::exists(dir / "pipe" / "control"); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  std::error_code ec;
  fs::remove_all(dir, ec);
}

}  // namespace ff::cli::sweep
