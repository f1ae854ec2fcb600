#pragma once
/// @file Process.h
/// @brief Test helpers that run a program (the `lsdem` binary) as a child
/// process, as a user runs it from a shell.

#include <spawn.h>
#include <sys/types.h>
#include <sys/wait.h>

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

}  // namespace lsdem::test
