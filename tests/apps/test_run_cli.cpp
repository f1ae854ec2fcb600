// `lsdem run` as a user runs it: Ctrl-C and SIGTERM stop cleanly (final
// summary and checkpoint written, exit code 130 / 143) and `--resume`
// continues the run.

#include <gtest/gtest.h>

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

namespace fs = std::filesystem;
extern char** environ;

namespace {

const char* kLongScene = R"([simulation]
dimension = 2
duration = 1000.0

[contact]
kn = 1e5
damping_ratio = 0.2

[shapes.disc]
kind = "circle"
radius = 0.01
cells_across = 12

[[particles]]
shape = "disc"
density = 2000.0
placement = "grid"
region = { min = [0.0, 0.0], max = [0.2, 0.2] }

[[planes]]
name = "floor"
point = [0.0, 0.0]
normal = [0.0, 1.0]

[effects]
gravity = [0.0, -9.81]

[output]
frames = 100000
history_rows = 100000
)";

std::string readFile(const fs::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

int runToExit(const std::vector<std::string>& args) {
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ) != 0) return -1;
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace

TEST(RunCli, CtrlCStopsCleanlyAndResumeContinues) {
  const fs::path dir = fs::temp_directory_path() / "lsdem_test_run_cli";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path scene = dir / "long.toml";
  std::ofstream(scene) << kLongScene;
  const fs::path out = dir / "out";

  // Start a run that would take hours; interrupt it once it has written frames.
  std::vector<std::string> args = {LSDEM_BINARY, "run", scene.string(), "--out", out.string(), "--quiet"};
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = 0;
  ASSERT_EQ(posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ), 0);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!fs::exists(out / "frames" / "particles_000003.vtp") && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_TRUE(fs::exists(out / "frames" / "particles_000003.vtp")) << "the run did not start";
  kill(pid, SIGINT);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 130);
  EXPECT_NE(readFile(out / "summary.json").find("\"stopped_early\": true"), std::string::npos);
  EXPECT_TRUE(fs::exists(out / "checkpoint.lsc"));

  // Resume for a few more steps.
  EXPECT_EQ(runToExit({LSDEM_BINARY, "run", "--resume", out.string(), "--steps", "20", "--quiet"}), 0);
  EXPECT_NE(readFile(out / "summary.json").find("\"stopped_early\": false"), std::string::npos);
  // Neither a scene nor --resume: a usage error.
  EXPECT_NE(runToExit({LSDEM_BINARY, "run", "--quiet"}), 0);
  fs::remove_all(dir);
}

// SIGTERM (a job scheduler's stop) is handled like Ctrl-C: checkpoint,
// summary, exit code 143 (128 + 15), and the run resumes.
TEST(RunCli, SigtermStopsCleanlyWithCode143) {
  const fs::path dir = fs::temp_directory_path() / "lsdem_test_run_cli_term";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path scene = dir / "long.toml";
  std::ofstream(scene) << kLongScene;
  const fs::path out = dir / "out";
  std::vector<std::string> args = {LSDEM_BINARY, "run", scene.string(), "--out", out.string(), "--quiet"};
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = 0;
  ASSERT_EQ(posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ), 0);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!fs::exists(out / "frames" / "particles_000003.vtp") && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_TRUE(fs::exists(out / "frames" / "particles_000003.vtp")) << "the run did not start";
  kill(pid, SIGTERM);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status)) << "killed by the signal instead of stopping";
  EXPECT_EQ(WEXITSTATUS(status), 143);
  EXPECT_NE(readFile(out / "summary.json").find("\"stopped_early\": true"), std::string::npos);
  EXPECT_EQ(runToExit({LSDEM_BINARY, "run", "--resume", out.string(), "--steps", "5", "--quiet"}), 0);
  fs::remove_all(dir);
}
