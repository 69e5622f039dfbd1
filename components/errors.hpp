// The errors a caller of the engine handles: bad input and geometry the mesher cannot honour. Here, with the
// plain data, because both layers throw them: engine/ (scenario loading, interactive calls) and systems/
// (meshing), and systems depend on components only, never on engine.
#pragma once

#include <stdexcept>

namespace pt {

// One clear line: "<file>: <json path>: <problem>" (or "<file>: <geometric problem>").
struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A geometric problem of the input (self-intersecting outline, point outside, ...). The message is one
// line that names the problem; the caller adds the file name.
struct GeometryError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace pt
