// `lsdem run` as a user runs it: Ctrl-C and SIGTERM stop cleanly (final
// summary and checkpoint written, exit code 130 / 143) and `--resume`
// continues the run.

#include "support/Process.h"

#include <gtest/gtest.h>

#include <signal.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

namespace fs = std::filesystem;
using lsdem::test::runToExit;

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

// Starts the long scene into `out` (under `dir`), waits until it has written
// three frames and sends it `signal`; its exit code (-1: it never wrote the
// frames, or the signal killed it instead of stopping it).
int interruptedRun(const fs::path& dir, const fs::path& out, int signal) {
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path scene = dir / "long.toml";
  std::ofstream(scene) << kLongScene;
  const pid_t pid = lsdem::test::spawnProcess({LSDEM_BINARY, "run", scene.string(), "--out", out.string(), "--quiet"});
  if (pid < 0) {
    ADD_FAILURE() << "lsdem did not start";
    return -1;
  }
  const fs::path frame = out / "frames" / "particles_000003.vtp";
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!fs::exists(frame) && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  const bool started = fs::exists(frame);
  kill(pid, started ? signal : SIGKILL);
  const int code = lsdem::test::waitForExit(pid);
  if (!started) {
    ADD_FAILURE() << "the run did not start";
    return -1;
  }
  return code;
}

}  // namespace

TEST(RunCli, CtrlCStopsCleanlyAndResumeContinues) {
  // Start a run that would take hours; interrupt it once it has written frames.
  const fs::path dir = fs::temp_directory_path() / "lsdem_test_run_cli";
  const fs::path out = dir / "out";
  ASSERT_EQ(interruptedRun(dir, out, SIGINT), 130);
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
  const fs::path out = dir / "out";
  ASSERT_EQ(interruptedRun(dir, out, SIGTERM), 143) << "killed by the signal instead of stopping";
  EXPECT_NE(readFile(out / "summary.json").find("\"stopped_early\": true"), std::string::npos);
  EXPECT_EQ(runToExit({LSDEM_BINARY, "run", "--resume", out.string(), "--steps", "5", "--quiet"}), 0);
  fs::remove_all(dir);
}
