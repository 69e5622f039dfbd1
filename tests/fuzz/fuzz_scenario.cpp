// libFuzzer target (issue 9): the scenario loader on arbitrary bytes. parse_scenario (which validates) may
// only ever throw InputError or GeometryError; anything else (another exception, a sanitizer report, a
// crash, a hang) is a finding. A scenario that loads must also pass validate_scenario again (idempotent)
// and its InputError messages must be one line.
#include "engine/scenario.hpp"
#include "systems/meshing.hpp"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

namespace {

[[noreturn]] void finding(const char* what, const std::string& detail) {
  std::fprintf(stderr, "fuzz_scenario: %s: %s\n", what, detail.c_str());
  std::abort();
}

void check_message(const char* what) {
  const std::string m(what);
  if (m.empty()) finding("empty error message", "");
  if (m.find('\n') != std::string::npos) finding("multi-line error message", m);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const pt::Scenario s = pt::parse_scenario(text, "fuzz.json");
    try {
      pt::validate_scenario(s);
    } catch (const std::exception& e) {
      finding("a parsed scenario fails validate_scenario", e.what());
    }
  } catch (const pt::InputError& e) {
    check_message(e.what());
  } catch (const pt::GeometryError& e) {
    check_message(e.what());
  } catch (const std::exception& e) {
    finding("unexpected exception", e.what());
  } catch (...) {
    finding("unexpected non-std exception", "");
  }
  return 0;
}
