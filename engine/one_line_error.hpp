// The programs' diagnostics (the command line, tools/): scripts read stderr line by line, so every message
// is exactly one line, "<program>: <message>", whatever line breaks the message carried.
#pragma once

#include <cstdio>
#include <string>

namespace pt {

inline void print_one_line_error(const char* program, const std::string& message) {
  std::string line = std::string(program) + ": ";
  for (const char c : message) line += (c == '\n' || c == '\r') ? ' ' : c;
  std::fprintf(stderr, "%s\n", line.c_str());
  std::fflush(stderr);
}

}  // namespace pt
