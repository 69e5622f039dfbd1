// Recording an interactive session (issue 7) as a scenario (docs/scenario-format.md) that `papertear run`
// replays: the scenario's sheet, material (the sheet's current values), detail and sim settings with
// `sim.frames` = frames played, its hands, and every finger with its pattern point, its keys and — for
// fingers put on or let go during the session — "attach" / "release" times in seconds.
#pragma once

#include "engine/simulation.hpp"

#include <nlohmann/json.hpp>

#include <string>

namespace pt::viewer {

// The session so far as scenario JSON. `name`: the scenario name ("" → "<scenario>-session").
nlohmann::json session_json(const Simulation& sim, const std::string& name = "");

// Writes session_json to `path` (pretty, 2 spaces; doubles round-trip exactly). Throws std::runtime_error.
void write_session(const Simulation& sim, const std::string& path, const std::string& name = "");

}  // namespace pt::viewer
