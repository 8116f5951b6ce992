// The offline tools run end to end from the tools' tests: a command line quoted for the shell, its
// exit code, stdout and stderr; optionally under a time limit and a memory limit, so that a tool
// that would block or read forever fails its test instead of holding the run up.
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "test_files.h"

namespace mvod {
namespace test {

inline std::string quote(const std::string& arg) {
  std::string quoted = "'";
  for (const char c : arg) {
    if (c == '\'') {
      quoted += "'\\''";
    } else {
      quoted += c;
    }
  }
  return quoted + "'";
}

struct RunResult {
  int exit_code = -1;  // 137: killed at the time limit (or another SIGKILL)
  std::string out;
  std::string err;
};

struct RunLimits {
  int timeout_s = 0;    // 0: none; else SIGKILL after this long (timeout(1))
  long memory_kib = 0;  // 0: none; else the tool's address space (ulimit -v)
};

// `binary` with `args` in the shell, stdin from /dev/null, stdout and stderr into `work_dir`.
inline RunResult runTool(const std::string& binary, const std::vector<std::string>& args,
                         const std::filesystem::path& work_dir, const RunLimits& limits = {}) {
  std::string command;
  if (limits.memory_kib > 0) command += "ulimit -v " + std::to_string(limits.memory_kib) + "; ";
  if (limits.timeout_s > 0) command += "timeout -s KILL " + std::to_string(limits.timeout_s) + " ";
  command += quote(binary);
  for (const std::string& arg : args) command += " " + quote(arg);
  const std::filesystem::path out = work_dir / "stdout.txt";
  const std::filesystem::path err = work_dir / "stderr.txt";
  command += " > " + quote(out.string()) + " 2> " + quote(err.string()) + " < /dev/null";
  const int status = std::system(command.c_str());
  RunResult result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  result.out = readText(out);
  result.err = readText(err);
  return result;
}

}  // namespace test
}  // namespace mvod
