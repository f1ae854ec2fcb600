/// @file ParaviewCommand.cpp
/// @brief `lsdem paraview DIR [--screenshot FILE.png] [--time T] [--size WxH]
/// [--color FIELD] [--state FILE.pvsm]`: a run folder in ParaView with a ready
/// view (docs/paraview.md "One command"), by running the shipped pvpython
/// script `paraview_view.py` with ParaView's `pvpython`.
///
/// The script is looked for, first found wins:
///  1. `$LSDEM_PARAVIEW_SCRIPT`, when set (a copy of one's own);
///  2. the installed copy, `<lsdem's folder>/<bindir-to-datadir>/lsdem/scripts/paraview_view.py`
///     (`../share/lsdem/scripts/` under the default layout), found from the
///     running executable (/proc/self/exe), so any install prefix works;
///  3. the source tree lsdem was built from, `<source>/scripts/paraview_view.py`
///     (a binary run from its build folder).
/// pvpython: the first `pvpython` on PATH, else /usr/bin/pvpython. With
/// `--screenshot` or `--state` and no display ($DISPLAY and $WAYLAND_DISPLAY unset),
/// pvpython runs under `xvfb-run -a` when that is installed (Debian's
/// ParaView renders through X even offscreen).
///
/// A screenshot or state run that pvpython aborts (SIGABRT: Debian's 5.11 under Xvfb
/// now and then fails to connect at start) is tried again, five runs at most.
///
/// Exit codes: 2 when DIR is not a run folder, an option is bad, pvpython
/// (or the script) is not installed; otherwise pvpython's own exit code
/// (the script: 0 done, 1 failed, 2 bad input).

#include "Commands.h"

#include "lsdem/io/InputError.h"

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <csignal>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#ifndef LSDEM_SOURCE_DIR
#define LSDEM_SOURCE_DIR ""
#endif
#ifndef LSDEM_BIN_TO_SCRIPTS
#define LSDEM_BIN_TO_SCRIPTS "../share/lsdem/scripts"
#endif

namespace lsdem::apps {
namespace {

namespace fs = std::filesystem;

constexpr const char* kScriptName = "paraview_view.py";
constexpr std::array<const char*, 4> kSeries = {"particles.pvd", "surfaces.pvd", "boundaries.pvd", "contacts.pvd"};

bool isExecutable(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec) && access(p.c_str(), X_OK) == 0;
}

// The first executable `name` in a PATH entry (an empty entry is the current folder).
std::optional<fs::path> onPath(const std::string& name) {
  const char* path = std::getenv("PATH");
  if (!path) return std::nullopt;
  std::istringstream entries(path);
  for (std::string dir; std::getline(entries, dir, ':');) {
    const fs::path candidate = (dir.empty() ? fs::current_path() : fs::path(dir)) / name;
    if (isExecutable(candidate)) return candidate;
  }
  return std::nullopt;
}

std::optional<fs::path> findPvpython() {
  if (auto p = onPath("pvpython")) return p;
  if (isExecutable("/usr/bin/pvpython")) return fs::path("/usr/bin/pvpython");
  return std::nullopt;
}

// The script by the rule in the file comment; `looked` collects the places tried.
std::optional<fs::path> findScript(std::vector<std::string>& looked) {
  std::error_code ec;
  if (const char* env = std::getenv("LSDEM_PARAVIEW_SCRIPT"); env && *env) {
    looked.emplace_back(env);
    if (fs::is_regular_file(env, ec)) return fs::path(env);
    return std::nullopt;  // set but wrong: say so rather than run another copy
  }
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path installed = (exe.parent_path() / LSDEM_BIN_TO_SCRIPTS / kScriptName).lexically_normal();
    looked.push_back(installed.string());
    if (fs::is_regular_file(installed, ec)) return installed;
  }
  if (std::strlen(LSDEM_SOURCE_DIR) > 0) {
    const fs::path source = fs::path(LSDEM_SOURCE_DIR) / "scripts" / kScriptName;
    looked.push_back(source.string());
    if (fs::is_regular_file(source, ec)) return source;
  }
  return std::nullopt;
}

bool hasDisplay() {
  const char* x = std::getenv("DISPLAY");
  const char* w = std::getenv("WAYLAND_DISPLAY");
  return (x && *x) || (w && *w);
}

// Runs argv[0] with argv, waits, returns its exit code (128 + signal when killed).
int runAndWait(const std::vector<std::string>& argv) {
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  std::cout.flush();
  std::cerr.flush();
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error(std::string("cannot start pvpython: ") + std::strerror(errno));
  if (pid == 0) {
    execv(args[0], args.data());
    std::fprintf(stderr, "lsdem paraview: cannot run %s: %s\n", args[0], std::strerror(errno));
    _exit(127);
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) throw std::runtime_error(std::string("waiting for pvpython: ") + std::strerror(errno));
  }
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return 1;
}

}  // namespace

void addParaviewCommand(CLI::App& app) {
  struct Options {
    std::string dir;
    std::string screenshot;
    std::optional<double> time;
    std::string size;
    std::string color;
    std::string state;
  };
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "paraview", "open a run folder in ParaView with a ready view, or save a screenshot (needs pvpython)");
  cmd->add_option("dir", opts->dir, "a run's output folder (particles.pvd, surfaces.pvd, boundaries.pvd, contacts.pvd)")
      ->required();
  cmd->add_option("--screenshot", opts->screenshot, "render offscreen and save this PNG instead of opening the GUI");
  cmd->add_option("--time", opts->time, "simulated time to show, s (the nearest frame; default the last)");
  cmd->add_option("--size", opts->size, "screenshot size WxH in pixels, 64 to 8000 each (default 1200x800)");
  cmd->add_option("--color", opts->color,
                  "surfaces coloured by: auto (generation once a grain has broken, else id), id, generation");
  cmd->add_option("--state", opts->state, "save a ParaView state file (.pvsm) instead of opening the GUI");
  cmd->callback([opts] {
    // DIR first, so bad input is reported before a missing tool.
    std::error_code ec;
    if (!fs::is_directory(opts->dir, ec)) throw io::InputError(opts->dir, 0, "", "not a folder");
    bool any = false;
    for (const char* s : kSeries) any = any || fs::is_regular_file(fs::path(opts->dir) / s, ec);
    if (!any) {
      throw io::InputError(opts->dir, 0, "",
                           "not a run folder (none of particles.pvd, surfaces.pvd, boundaries.pvd, contacts.pvd)");
    }
    if (opts->time && !(std::isfinite(*opts->time) && *opts->time >= 0.0)) {
      std::ostringstream given;
      given << *opts->time;
      throw io::InputError("--time", 0, "", "must be a finite number >= 0 (s), got " + given.str());
    }
    if (!opts->size.empty()) imageSize(opts->size);
    if (!opts->color.empty() && opts->color != "auto" && opts->color != "id" && opts->color != "generation") {
      throw io::InputError("--color", 0, "", "expected 'auto', 'id' or 'generation', got '" + opts->color + "'");
    }
    if (!opts->screenshot.empty() && !opts->state.empty()) {
      throw io::InputError("--state", 0, "", "give either --screenshot or --state, not both");
    }
    // The file's folder must exist (as for render): a typo is not a new folder.
    for (const auto& [option, file] : {std::pair{"--screenshot", &opts->screenshot}, std::pair{"--state", &opts->state}}) {
      if (file->empty()) continue;
      const fs::path folder = fs::absolute(fs::path(*file)).parent_path();
      std::error_code ec;
      if (!fs::is_directory(folder, ec)) {
        throw io::InputError(option, 0, "", "folder '" + folder.string() + "' does not exist");
      }
    }

    const std::optional<fs::path> pvpython = findPvpython();
    if (!pvpython) {
      std::cerr << "lsdem paraview: pvpython is not installed (apt-get install paraview python3-paraview); open "
                << (fs::path(opts->dir) / "particles.pvd").string() << " in any ParaView (docs/paraview.md)\n";
      throw CLI::RuntimeError(2);
    }
    std::vector<std::string> looked;
    const std::optional<fs::path> script = findScript(looked);
    if (!script) {
      std::string where;
      for (const std::string& l : looked) where += (where.empty() ? "" : ", ") + l;
      std::cerr << "lsdem paraview: " << kScriptName << " not found (looked at " << where
                << "); reinstall lsdem or set LSDEM_PARAVIEW_SCRIPT\n";
      throw CLI::RuntimeError(2);
    }

    std::vector<std::string> argv;
    const bool offscreen = !opts->screenshot.empty() || !opts->state.empty();
    if (offscreen && !hasDisplay()) {
      if (const auto xvfb = onPath("xvfb-run")) argv = {xvfb->string(), "-a"};
    }
    argv.push_back(pvpython->string());
    argv.push_back(script->string());
    argv.push_back(opts->dir);
    if (!opts->screenshot.empty()) argv.insert(argv.end(), {"--screenshot", opts->screenshot});
    if (!opts->state.empty()) argv.insert(argv.end(), {"--state", opts->state});
    if (opts->time) {
      std::ostringstream t;
      t.precision(17);
      t << *opts->time;
      argv.insert(argv.end(), {"--time", t.str()});
    }
    if (!opts->size.empty()) argv.insert(argv.end(), {"--size", opts->size});
    if (!opts->color.empty()) argv.insert(argv.end(), {"--color", opts->color});
    // Debian's ParaView 5.11 under Xvfb now and then aborts at start ("bad X
    // server connection", SIGABRT; about one run in eight on the machine it was
    // checked on) before it has done anything: a screenshot or state is tried up to five times.
    int code = 0;
    for (int attempt = 1; attempt <= 5; ++attempt) {
      code = runAndWait(argv);
      if (!offscreen || code != 128 + SIGABRT || attempt == 5) break;
      std::cerr << "lsdem paraview: pvpython aborted (exit " << code << "), trying again\n";
    }
    if (code != 0) throw CLI::RuntimeError(code);
  });
}

}  // namespace lsdem::apps
