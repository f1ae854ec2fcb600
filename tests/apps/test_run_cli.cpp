// `lsdem run` as a user runs it: Ctrl-C and SIGTERM stop cleanly (final
// summary and checkpoint written, exit code 130 / 143) and `--resume`
// continues the run; an output folder holds one run at a time (its lock
// file) and another run's outputs are not overwritten unless asked.

#include "support/Files.h"
#include "support/Process.h"

#include <gtest/gtest.h>

#include <signal.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <thread>
#include <tuple>
#include <vector>

namespace fs = std::filesystem;
using lsdem::test::runCaptured;
using lsdem::test::runToExit;

using lsdem::test::readFile;

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

std::size_t lineCount(const std::string& text) { return std::size_t(std::count(text.begin(), text.end(), '\n')); }

// Writes the long scene into `dir` (emptied first); its path.
fs::path longScene(const fs::path& dir) {
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path scene = dir / "long.toml";
  std::ofstream(scene) << kLongScene;
  return scene;
}

// Starts the long scene into `out` (under `dir`) and waits until it has
// written three frames; its pid, or -1 (then it is killed).
pid_t startLongRun(const fs::path& dir, const fs::path& out) {
  const fs::path scene = longScene(dir);
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
  if (!fs::exists(frame)) {
    kill(pid, SIGKILL);
    lsdem::test::waitForExit(pid);
    ADD_FAILURE() << "the run did not start";
    return -1;
  }
  return pid;
}

// Starts the long scene into `out` (under `dir`), waits until it has written
// three frames and sends it `signal`; its exit code (-1: it never wrote the
// frames, or the signal killed it instead of stopping it).
int interruptedRun(const fs::path& dir, const fs::path& out, int signal) {
  const pid_t pid = startLongRun(dir, out);
  if (pid < 0) return -1;
  kill(pid, signal);
  return lsdem::test::waitForExit(pid);
}

}  // namespace

TEST(RunCli, CtrlCStopsCleanlyAndResumeContinues) {
  // Start a run that would take hours; interrupt it once it has written frames.
  const fs::path dir = lsdem::test::tempPath("lsdem_test_run_cli");
  const fs::path out = dir / "out";
  ASSERT_EQ(interruptedRun(dir, out, SIGINT), 130);
  EXPECT_NE(readFile(out / "summary.json").find("\"stopped_early\": true"), std::string::npos);
  EXPECT_TRUE(fs::exists(out / "checkpoint.lsc"));
  EXPECT_FALSE(fs::exists(out / "lsdem.lock")) << "the lock is removed when Ctrl-C stops the run";

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
  const fs::path dir = lsdem::test::tempPath("lsdem_test_run_cli_term");
  const fs::path out = dir / "out";
  ASSERT_EQ(interruptedRun(dir, out, SIGTERM), 143) << "killed by the signal instead of stopping";
  EXPECT_NE(readFile(out / "summary.json").find("\"stopped_early\": true"), std::string::npos);
  EXPECT_FALSE(fs::exists(out / "lsdem.lock")) << "the lock is removed when SIGTERM stops the run";
  EXPECT_EQ(runToExit({LSDEM_BINARY, "run", "--resume", out.string(), "--steps", "5", "--quiet"}), 0);
  EXPECT_FALSE(fs::exists(out / "lsdem.lock"));
  fs::remove_all(dir);
}

// A new run into a folder that holds another run's outputs is refused with
// one line and exit code 2, and nothing in it changes; --overwrite replaces
// those outputs (the old run's later frames go too), --resume continues them.
TEST(RunCli, AnotherRunsOutputsAreRefusedUnlessOverwrite) {
  const fs::path dir = lsdem::test::tempPath("lsdem_test_run_cli_overwrite");
  const fs::path out = dir / "out";
  const fs::path scene = longScene(dir);
  const std::vector<std::string> run = {LSDEM_BINARY, "run", scene.string(), "--out", out.string(), "--quiet"};
  const auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = run;
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  };
  ASSERT_EQ(runToExit(with({"--steps", "5"})), 0);
  const std::string history = readFile(out / "history.csv");
  ASSERT_TRUE(fs::exists(out / "frames" / "particles_000005.vtp"));

  const lsdem::test::ProcessResult again = runCaptured(with({"--steps", "2"}));
  EXPECT_EQ(again.code, 2) << again.output;
  EXPECT_EQ(lineCount(again.output), 1u) << again.output;
  EXPECT_EQ(again.output.rfind("lsdem: " + out.string() + ": holds the outputs of another run (summary.json", 0), 0u)
      << again.output;
  EXPECT_NE(again.output.find("--overwrite"), std::string::npos) << again.output;
  EXPECT_EQ(readFile(out / "history.csv"), history) << "a refused run changes nothing";
  // The same folder named another way is refused alike.
  EXPECT_EQ(runToExit({LSDEM_BINARY, "run", scene.string(), "--out", out.string() + "/", "--quiet"}), 2);

  // --resume continues the run in the folder.
  EXPECT_EQ(runToExit({LSDEM_BINARY, "run", "--resume", out.string(), "--steps", "1", "--quiet"}), 0);
  // --overwrite starts afresh: two steps, three frames; the old frames 3-6 are gone.
  ASSERT_EQ(runToExit(with({"--steps", "2", "--overwrite"})), 0);
  EXPECT_EQ(lineCount(readFile(out / "history.csv")), 1u + 3u);
  EXPECT_TRUE(fs::exists(out / "frames" / "particles_000002.vtp"));
  EXPECT_FALSE(fs::exists(out / "frames" / "particles_000003.vtp"));
  EXPECT_FALSE(fs::exists(out / "lsdem.lock"));
  fs::remove_all(dir);
}

// Two runs into one folder at the same time: the second is stopped by the
// first's lock file (naming its pid), whether it starts afresh with
// --overwrite or resumes; the first is undisturbed and removes its lock when
// it ends.
TEST(RunCli, ASecondRunIntoABusyFolderIsStoppedByTheLock) {
  const fs::path dir = lsdem::test::tempPath("lsdem_test_run_cli_lock");
  const fs::path out = dir / "out";
  const pid_t first = startLongRun(dir, out);
  ASSERT_GT(first, 0);
  EXPECT_EQ(readFile(out / "lsdem.lock"), std::to_string(first) + "\n");
  const std::string lockHeld = "lsdem: " + (out / "lsdem.lock").string() + ": another lsdem run (pid " +
                               std::to_string(first) + ") is writing into this folder";
  for (const std::vector<std::string>& second :
       {std::vector<std::string>{LSDEM_BINARY, "run", (dir / "long.toml").string(), "--out", out.string(), "--overwrite",
                                 "--steps", "2", "--quiet"},
        std::vector<std::string>{LSDEM_BINARY, "run", "--resume", out.string(), "--steps", "2", "--quiet"}}) {
    const lsdem::test::ProcessResult r = runCaptured(second);
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_EQ(lineCount(r.output), 1u) << r.output;
    EXPECT_EQ(r.output.rfind(lockHeld, 0), 0u) << r.output;
  }
  kill(first, SIGINT);
  EXPECT_EQ(lsdem::test::waitForExit(first), 130);
  EXPECT_FALSE(fs::exists(out / "lsdem.lock"));
  EXPECT_NE(readFile(out / "summary.json").find("\"stopped_early\": true"), std::string::npos);
  fs::remove_all(dir);
}

// A lock file left by a run that was killed (SIGKILL: no clean-up) names a
// dead process: the next run takes it over.
TEST(RunCli, AStaleLockOfAKilledRunIsTakenOver) {
  const fs::path dir = lsdem::test::tempPath("lsdem_test_run_cli_stale");
  const fs::path out = dir / "out";
  const pid_t killed = startLongRun(dir, out);
  ASSERT_GT(killed, 0);
  kill(killed, SIGKILL);
  EXPECT_EQ(lsdem::test::waitForExit(killed), -1);
  ASSERT_EQ(readFile(out / "lsdem.lock"), std::to_string(killed) + "\n") << "SIGKILL leaves the lock file";
  EXPECT_EQ(runToExit({LSDEM_BINARY, "run", (dir / "long.toml").string(), "--out", out.string(), "--overwrite",
                       "--steps", "2", "--quiet"}),
            0);
  EXPECT_FALSE(fs::exists(out / "lsdem.lock"));
  fs::remove_all(dir);
}

// A resume with an edited scene is refused in one line with exit code 2
// (the run's outputs unchanged); --force resumes with it as it is now;
// --force without --resume is a usage error.
TEST(RunCli, ResumeWithAnEditedSceneNeedsForce) {
  const fs::path dir = lsdem::test::tempPath("lsdem_test_run_cli_force");
  const fs::path out = dir / "out";
  const fs::path scene = longScene(dir);
  ASSERT_EQ(runToExit({LSDEM_BINARY, "run", scene.string(), "--out", out.string(), "--steps", "3", "--quiet"}), 0);
  std::ofstream(scene, std::ios::app) << "progress_seconds = 5.0\n";
  const std::string history = readFile(out / "history.csv");
  const lsdem::test::ProcessResult refused =
      runCaptured({LSDEM_BINARY, "run", "--resume", out.string(), "--steps", "2", "--quiet"});
  EXPECT_EQ(refused.code, 2) << refused.output;
  EXPECT_EQ(refused.output, "lsdem: " + scene.string() + ": the scene file changed since the checkpoint in " +
                                out.string() + " was written; give --force to resume with it anyway\n");
  EXPECT_EQ(readFile(out / "history.csv"), history);
  const lsdem::test::ProcessResult forced =
      runCaptured({LSDEM_BINARY, "run", "--resume", out.string(), "--steps", "2", "--force", "--quiet"});
  EXPECT_EQ(forced.code, 0) << forced.output;
  EXPECT_NE(forced.output.find("anyway (--force)"), std::string::npos) << forced.output;
  EXPECT_EQ(readFile(out / "scene.toml"), readFile(scene));
  // The run's rows stay on its clock (steps, from its --steps), though the
  // scene's end is in seconds: one per step, 0 to 5.
  const std::string rows = readFile(out / "history.csv");
  EXPECT_EQ(std::count(rows.begin(), rows.end(), '\n'), 1 + 6) << rows;
  // Edited again and forced without --steps: the scene's end is in seconds,
  // the run's outputs in steps: refused in one line, with no note that it
  // was resumed anyway (the note came first).
  std::ofstream(scene, std::ios::app) << "# edited\n";
  const lsdem::test::ProcessResult clocks =
      runCaptured({LSDEM_BINARY, "run", "--resume", out.string(), "--force", "--quiet"});
  EXPECT_EQ(clocks.code, 2) << clocks.output;
  EXPECT_EQ(std::count(clocks.output.begin(), clocks.output.end(), '\n'), 1) << clocks.output;
  EXPECT_NE(clocks.output.find("the run's outputs are scheduled in steps and the scene's end is in seconds: resume "
                               "it with --steps N (N more steps)"),
            std::string::npos)
      << clocks.output;
  EXPECT_EQ(readFile(out / "history.csv"), rows);
  EXPECT_EQ(runToExit({LSDEM_BINARY, "run", scene.string(), "--out", out.string(), "--force", "--quiet"}), 2);
  fs::remove_all(dir);
}

// Progress written to a log (stderr not a terminal) keeps every field, in
// the order scripts parse (`step N ... M contacts`), whatever its width;
// the 80-column line is for terminals only.
TEST(RunCli, ALogGetsWholeProgressLines) {
  const fs::path dir = lsdem::test::tempPath("lsdem_test_run_cli_log");
  const fs::path out = dir / "out";
  const fs::path scene = longScene(dir);
  const lsdem::test::ProcessResult r =
      runCaptured({LSDEM_BINARY, "run", scene.string(), "--out", out.string(), "--steps", "3"});
  ASSERT_EQ(r.code, 0) << r.output;
  const std::regex line(
      R"(step (\d+)  t = \S+ s \(\S+%\)  \d+ steps/s  (\d+) particles  (\d+) contacts  (\d+) breakages  wall \S.*)");
  std::istringstream lines(r.output);
  std::string text;
  std::vector<std::string> fields;  // step, particles, contacts, breakages of the last line matched
  std::size_t matched = 0;
  while (std::getline(lines, text)) {
    std::smatch m;
    if (std::regex_match(text, m, line)) {
      fields = {m[1].str(), m[2].str(), m[3].str(), m[4].str()};
      ++matched;
    }
  }
  ASSERT_EQ(matched, 1u) << r.output;  // the closing line (a 3-step run shows no other)
  EXPECT_EQ(fields[0], "3");
  EXPECT_EQ(fields[1], "64");  // the scene's grid placement
  EXPECT_EQ(fields[3], "0");
  fs::remove_all(dir);
}

namespace {

// Files in `dir` and below whose name ends in ".tmp".
std::size_t temporaryFiles(const fs::path& dir) {
  std::size_t n = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir)) n += e.path().extension() == ".tmp";
  return n;
}

}  // namespace

// A write that fails (here a file size limit, as a full disk) stops the run
// at once: exit code 1, one line naming the file and the reason, no
// temporary file or lock left. The last periodic checkpoint stays whole: the
// run resumes from it once the limit is gone, its history cut back to whole rows.
TEST(RunCli, AFailedWriteStopsTheRunNamingTheFile) {
  const fs::path dir = lsdem::test::tempPath("lsdem_test_run_cli_full");
  const fs::path scene = longScene(dir);
  std::string text = kLongScene;
  text.replace(text.find("frames = 100000"), 15, "frames = 10\ncheckpoint_every = 0.05");
  text.replace(text.find("history_rows = 100000"), 21, "history_rows = 100000000");  // a row per step
  std::ofstream(scene, std::ios::trunc) << text;
  const auto runLimited = [&](const fs::path& out, long long limit) {
    return runCaptured({LSDEM_BINARY, "run", scene.string(), "--out", out.string(), "--quiet"}, limit);
  };

  // history.csv reaches 200 kB first.
  const fs::path out = dir / "history";
  const lsdem::test::ProcessResult history = runLimited(out, 200000);
  EXPECT_EQ(history.code, 1) << history.output;
  // One line: the step it stopped at, then the file.
  const std::string tail = "cannot write " + (out / "history.csv").string() + ": File too large\n";
  EXPECT_EQ(history.output.rfind("lsdem: error: after step ", 0), 0u) << history.output;
  EXPECT_TRUE(history.output.ends_with(" s): " + tail)) << history.output;
  EXPECT_EQ(std::count(history.output.begin(), history.output.end(), '\n'), 1) << history.output;
  EXPECT_EQ(fs::file_size(out / "history.csv"), 200000u);
  EXPECT_FALSE(fs::exists(out / "lsdem.lock"));
  EXPECT_EQ(temporaryFiles(out), 0u);
  ASSERT_EQ(runToExit({LSDEM_BINARY, "run", "--resume", out.string(), "--steps", "3", "--quiet"}), 0);
  const std::string rows = readFile(out / "history.csv");
  EXPECT_EQ(rows.find('\0'), std::string::npos);
  EXPECT_EQ(rows.back(), '\n');
  std::istringstream lines(rows);
  std::string header;
  std::getline(lines, header);
  for (std::string row; std::getline(lines, row);) {
    ASSERT_EQ(std::count(row.begin(), row.end(), ','), std::count(header.begin(), header.end(), ',')) << row;
  }

  // 16 kB: the first particles frame (compressed) fits, the first surfaces
  // frame (written to a temporary file, then renamed) is too large. The
  // run's first instant fails "after step 0", and its summary says so.
  const fs::path small = dir / "frame";
  const lsdem::test::ProcessResult frame = runLimited(small, 16384);
  EXPECT_EQ(frame.code, 1) << frame.output;
  const std::string frameError =
      "after step 0 (t = 0 s): cannot write '" + (small / "frames" / "surfaces_000000.vtp").string() +
      "': File too large";
  EXPECT_EQ(frame.output, "lsdem: error: " + frameError + "\n");
  const std::string frameSummary = readFile(small / "summary.json");
  EXPECT_NE(frameSummary.find("\"stopped_early\": true"), std::string::npos) << frameSummary;
  EXPECT_NE(frameSummary.find("\"error\": \"" + frameError + "\""), std::string::npos) << frameSummary;
  EXPECT_TRUE(fs::exists(small / "frames" / "particles_000000.vtp"));
  EXPECT_FALSE(fs::exists(small / "frames" / "surfaces_000000.vtp"));
  EXPECT_EQ(temporaryFiles(small), 0u);
  EXPECT_FALSE(fs::exists(small / "lsdem.lock"));

  // 8 kB: every output of the first step fits, the checkpoint of the run's
  // end (15 kB) does not. The run stops with that, and its summary says so.
  text = kLongScene;
  text.replace(text.find("frames = 100000"), 15, "frames = 0\ndistributions = 1");
  text.replace(text.find("history_rows = 100000"), 21, "history_rows = 2");
  std::ofstream(scene, std::ios::trunc) << text;
  const fs::path last = dir / "last";
  const lsdem::test::ProcessResult end =
      runCaptured({LSDEM_BINARY, "run", scene.string(), "--out", last.string(), "--quiet", "--steps", "5"}, 8192);
  EXPECT_EQ(end.code, 1) << end.output;
  const std::string checkpointError =
      "after step 5 (t = 0.0013 s): cannot write '" + (last / "checkpoint.lsc").string() + "': File too large";
  EXPECT_EQ(end.output, "lsdem: error: " + checkpointError + "\n");
  const std::string summary = readFile(last / "summary.json");
  EXPECT_NE(summary.find("\"stopped_early\": true"), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"error\": \"" + checkpointError + "\""), std::string::npos) << summary;
  EXPECT_EQ(temporaryFiles(last), 0u);
  EXPECT_FALSE(fs::exists(last / "lsdem.lock"));
  fs::remove_all(dir);
}

// A run whose last writes fail keeps a checkpoint of its end that says so:
// resumed, it makes them again, and ends as the run that never failed (it
// said "already at its end" and wrote nothing). The run goes there in parts
// (--steps), whose rows and frames stay on the run's own schedule (they were
// spread over each part's end). Its last frame is blocked by a folder of
// that name, made before a forced resume with a scene that ends later (a
// new run would clear the frames folder).
TEST(RunCli, ARunWhoseLastWritesFailedIsResumedToItsEndInParts) {
  const fs::path dir = lsdem::test::tempPath("lsdem_test_run_cli_last_writes");
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string shipped =
      readFile(fs::path(LSDEM_SOURCE_DIR) / "apps" / "scenes" / "three_grains" / "three_grains_2d.toml");
  // The shipped scene with frames, rows and size distributions every 0.01,
  // 0.0002 and 0.02 s, ending at `duration`.
  const auto scene = [&](const std::string& name, const char* duration, const char* frames, const char* rows,
                         const char* distributions) {
    std::string text = shipped;
    const auto set = [&](const std::string& key, const std::string& value) {
      const std::size_t at = text.find("\n" + key + " = ");
      ASSERT_NE(at, std::string::npos) << key;
      text.replace(at + 1, text.find('\n', at + 1) - at - 1, key + " = " + value);
    };
    set("duration", duration);
    set("frames", frames);
    set("history_rows", rows);
    set("distributions", distributions);
    std::ofstream(dir / name) << text;
  };
  scene("half.toml", "0.04", "4", "200", "3");
  scene("whole.toml", "0.08", "8", "400", "5");
  const auto lsdem = [&](std::vector<std::string> args) {
    args.insert(args.begin(), LSDEM_BINARY);
    args.push_back("--quiet");
    return runCaptured(args);
  };
  const fs::path ref = dir / "ref", out = dir / "out";
  ASSERT_EQ(lsdem({"run", (dir / "whole.toml").string(), "--out", ref.string()}).code, 0);
  ASSERT_EQ(lsdem({"run", (dir / "half.toml").string(), "--out", out.string()}).code, 0);
  const fs::path lastFrame = out / "frames" / "particles_000008.vtp";
  ASSERT_TRUE(fs::exists(ref / "frames" / "particles_000008.vtp"));
  fs::create_directories(lastFrame / "blocked");
  // A part of 2000 steps, then the rest, whose last frame fails, twice.
  const lsdem::test::ProcessResult part =
      lsdem({"run", "--resume", out.string(), (dir / "whole.toml").string(), "--force", "--steps", "2000"});
  EXPECT_EQ(part.code, 0) << part.output;
  for (int attempt = 0; attempt < 2; ++attempt) {
    const lsdem::test::ProcessResult failed = lsdem({"run", "--resume", out.string()});
    EXPECT_EQ(failed.code, 1) << failed.output;
    EXPECT_NE(failed.output.find("cannot write '" + lastFrame.string() + "'"), std::string::npos) << failed.output;
  }
  fs::remove_all(lastFrame);
  const lsdem::test::ProcessResult resumed = lsdem({"run", "--resume", out.string()});
  EXPECT_EQ(resumed.code, 0) << resumed.output;
  EXPECT_EQ(resumed.output.find("already at its end"), std::string::npos) << resumed.output;
  for (const char* file : {"history.csv", "psd.csv", "breakage_log.csv", "particles.pvd", "frames/particles_000008.vtp"}) {
    EXPECT_EQ(readFile(out / file), readFile(ref / file)) << file;
  }
  // Now whole: nothing more to do.
  const lsdem::test::ProcessResult again = lsdem({"run", "--resume", out.string()});
  EXPECT_EQ(again.code, 0) << again.output;
  fs::remove_all(dir);
}

// Command-line mistakes end in exit code 2 with a message naming what was
// given, and nothing written: a step count or thread count that is not a
// whole number in range, an unknown command, a folder given as the scene.
TEST(RunCli, CommandLineMistakesNameWhatWasGiven) {
  const fs::path dir = lsdem::test::tempPath("lsdem_test_run_cli_mistakes");
  const fs::path scene = longScene(dir);
  const fs::path out = dir / "out";
  const auto run = [&](std::vector<std::string> args) {
    args.insert(args.begin(), LSDEM_BINARY);
    return runCaptured(args);
  };
  for (const auto& [option, value, expected] :
       {std::tuple{"--steps", "0", "lsdem: --steps: must be a whole number >= 1, got '0'"},
        std::tuple{"--steps", "-5", "lsdem: --steps: must be a whole number >= 1, got '-5'"},
        std::tuple{"--steps", "2.5", "lsdem: --steps: must be a whole number >= 1, got '2.5'"},
        std::tuple{"--threads", "abc", "lsdem: --threads: must be a whole number in [0, 4096], got 'abc'"},
        std::tuple{"--threads", "4097", "lsdem: --threads: must be a whole number in [0, 4096], got '4097'"}}) {
    const lsdem::test::ProcessResult r = run({"run", scene.string(), "--out", out.string(), option, value});
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_EQ(r.output, std::string(expected) + " (lsdem run --help lists the options)\n");
    EXPECT_FALSE(fs::exists(out)) << option << ' ' << value;
  }
  const lsdem::test::ProcessResult unknown = run({"frobnicate"});
  EXPECT_EQ(unknown.code, 2);
  EXPECT_EQ(unknown.output.rfind("lsdem: unknown command 'frobnicate' (the commands: run, ", 0), 0u) << unknown.output;
  EXPECT_EQ(lineCount(unknown.output), 1u) << unknown.output;
  const lsdem::test::ProcessResult folder = run({"run", dir.string(), "--out", out.string()});
  EXPECT_EQ(folder.code, 2);
  EXPECT_EQ(folder.output, "lsdem: " + dir.string() + ": is a folder, not a TOML file\n");
  EXPECT_FALSE(fs::exists(out));
  fs::remove_all(dir);
}

// The smallest values the checks let through run (one step, all cores), and
// a run at its end resumed again says so in one line, exit 0, also with
// --quiet, and leaves every file as it was.
TEST(RunCli, AFinishedRunResumedAgainSaysSoAndWritesNothing) {
  const fs::path dir = lsdem::test::tempPath("lsdem_test_run_cli_finished");
  const fs::path scene = longScene(dir);
  const fs::path out = dir / "out";
  ASSERT_EQ(runToExit({LSDEM_BINARY, "run", scene.string(), "--out", out.string(), "--steps", "1", "--threads", "0",
                       "--quiet"}),
            0);
  const std::string summary = readFile(out / "summary.json");
  EXPECT_NE(summary.find("\"steps\": 1,"), std::string::npos) << summary;
  for (const char* quiet : {"--quiet", "--threads=1"}) {
    const lsdem::test::ProcessResult again = runCaptured({LSDEM_BINARY, "run", "--resume", out.string(), quiet});
    EXPECT_EQ(again.code, 0) << again.output;
    EXPECT_EQ(lineCount(again.output), 1u) << again.output;
    EXPECT_EQ(again.output.rfind("lsdem: " + out.string() + ": the run is already at its end (step 1, t = ", 0), 0u)
        << again.output;
    EXPECT_EQ(readFile(out / "summary.json"), summary);
  }
  fs::remove_all(dir);
}
