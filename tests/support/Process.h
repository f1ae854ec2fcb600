#pragma once
/// @file Process.h
/// @brief Test helpers that run a program (the `lsdem` binary) as a child
/// process, as a user runs it from a shell.

#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <string>
#include <vector>

extern char** environ;

namespace lsdem::test {

/// Starts `args[0]` with `args`; the child's pid, or -1 when it cannot start.
inline pid_t spawnProcess(const std::vector<std::string>& args) {
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ) != 0) return -1;
  return pid;
}

/// Waits for child `pid`; its exit code, or -1 when it did not exit normally
/// (a signal ended it).
inline int waitForExit(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/// Runs `args` to the end; its exit code, or -1 (not started, or ended by a signal).
inline int runToExit(const std::vector<std::string>& args) {
  const pid_t pid = spawnProcess(args);
  return pid < 0 ? -1 : waitForExit(pid);
}

/// What a finished child wrote and how it ended.
struct ProcessResult {
  int code = -1;       ///< exit code, -1 when it did not exit normally
  std::string output;  ///< stdout and stderr together
};

/// @brief Runs `args` to the end with its stdout and stderr captured.
/// @param fileSizeLimit when >= 0, the child's RLIMIT_FSIZE in bytes. The
/// child's SIGXFSZ is left as it is: lsdem ignores it itself, so that a
/// write past the limit fails with EFBIG, as on a full disk.
inline ProcessResult runCaptured(const std::vector<std::string>& args, long long fileSizeLimit = -1) {
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  ProcessResult r;
  int fds[2];
  if (pipe(fds) != 0) return r;
  const pid_t pid = fork();
  if (pid < 0) return r;
  if (pid == 0) {
    // The child: only async-signal-safe calls until exec.
    dup2(fds[1], 1);
    dup2(fds[1], 2);
    close(fds[0]);
    close(fds[1]);
    if (fileSizeLimit >= 0) {
      const rlimit limit{rlim_t(fileSizeLimit), rlim_t(fileSizeLimit)};
      setrlimit(RLIMIT_FSIZE, &limit);
    }
    execv(argv[0], argv.data());
    _exit(127);
  }
  close(fds[1]);
  char buf[4096];
  for (ssize_t n; (n = read(fds[0], buf, sizeof(buf))) > 0;) r.output.append(buf, std::size_t(n));
  close(fds[0]);
  r.code = waitForExit(pid);
  return r;
}

/// @brief Runs a shell command line to the end, as a user types it (so it
/// may start with variable assignments), with stdout and stderr captured
/// together.
inline ProcessResult runShell(const std::string& commandLine) {
  ProcessResult r;
  FILE* pipe = popen((commandLine + " 2>&1").c_str(), "r");
  if (!pipe) return r;
  std::array<char, 4096> buf;
  while (std::fgets(buf.data(), int(buf.size()), pipe)) r.output += buf.data();
  const int status = pclose(pipe);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

}  // namespace lsdem::test
