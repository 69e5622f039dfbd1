// Running papertear's programs from the tests (tests/engine/cli_test.cpp, tests/engine/batch_mpi_test.cpp): a command in
// a test's own directory, its exit status and what it printed.
#pragma once

#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace pt_test {

namespace fs = std::filesystem;

inline std::string read_file(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

inline void write_file(const fs::path& p, const std::string& text) {
  std::ofstream f(p, std::ios::binary);
  f << text;
}

// One shell word, whatever `s` holds.
inline std::string quote(const std::string& s) {
  std::string q = "'";
  for (const char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

struct Result {
  int status = -1;
  std::string out, err;
};

// `command` run by the shell in `dir` with no input; its stdout and stderr are read from files there,
// which are removed again. A signal's death is status 128 + the signal, as the shell reports it.
inline Result run_in(const fs::path& dir, const std::string& command) {
  // Appended piece by piece: GCC 12 warns falsely (-Wrestrict) on "cd " + std::string&& once inlined.
  std::string cmd = "cd ";
  cmd += quote(dir.string());
  cmd += " && ";
  cmd += command;
  cmd += " > stdout.txt 2> stderr.txt < /dev/null";
  const int raw = std::system(cmd.c_str());
  Result r;
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + (WIFSIGNALED(raw) ? WTERMSIG(raw) : 0);
  r.out = read_file(dir / "stdout.txt");
  r.err = read_file(dir / "stderr.txt");
  fs::remove(dir / "stdout.txt");
  fs::remove(dir / "stderr.txt");
  return r;
}

// Everything under `dir`, relative to it, sorted.
inline std::vector<std::string> listing(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::recursive_directory_iterator(dir)) names.push_back(e.path().lexically_relative(dir));
  std::sort(names.begin(), names.end());
  return names;
}

}  // namespace pt_test
