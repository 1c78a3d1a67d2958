// splitray train ...: trains the neural top builder (paper 003). Training needs libtorch, which
// the CLI must not link, so this command runs the separate `splitray-train` program (built from
// train/ only where find_package(Torch) succeeds) with the same arguments.
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "commands.hpp"
#include "splitray/core/errors.hpp"

namespace splitray::app {

namespace {

namespace fs = std::filesystem;

// Next to this binary (installed), or in the build tree (apps/splitray/../../train/).
fs::path find_trainer() {
  std::error_code error;
  const fs::path self = fs::read_symlink("/proc/self/exe", error);
  if (error) return {};
  const fs::path folder = self.parent_path();
  for (const fs::path& candidate :
       {folder / "splitray-train", folder / ".." / ".." / "train" / "splitray-train"}) {
    if (fs::exists(candidate, error) && ::access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return {};
}

void run(const std::vector<std::string>& args) {
  const fs::path trainer = find_trainer();
  if (trainer.empty())
    throw Error("train",
                "splitray train needs libtorch: install libtorch-dev (scripts/install-deps.sh) and "
                "rebuild (no splitray-train program next to splitray or in the build tree)");
  std::vector<std::string> owned{trainer.string()};
  owned.insert(owned.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& arg : owned) argv.push_back(arg.data());
  argv.push_back(nullptr);
  const pid_t child = ::fork();
  if (child < 0) throw Error("train", "cannot start " + trainer.string());
  if (child == 0) {
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  int status = 0;
  if (::waitpid(child, &status, 0) < 0) throw Error("train", "lost " + trainer.string());
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw Error("train", trainer.string() + " failed (exit status " +
                             std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + ")");
}

}  // namespace

void add_train_command(CLI::App& app) {
  auto args = std::make_shared<std::vector<std::string>>();
  CLI::App* sub = app.add_subcommand(
      "train",
      "Train the neural top builder (paper 003) with libtorch: --cost sah|vvh --depth D "
      "--samples M --data FILES... --out models/NAME.bin [--epochs E --batch B --lr LR]. Runs "
      "the splitray-train program (built only where libtorch is installed) with these arguments");
  sub->prefix_command();  // pass every argument, --help included, through to splitray-train
  sub->set_help_flag();   // so that --help reaches splitray-train's own, complete help
  sub->callback([sub, args] {
    *args = sub->remaining();
    run(*args);
  });
}

}  // namespace splitray::app
