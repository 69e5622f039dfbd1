// papertear: the one header an embedding program includes (installed as <papertear/papertear.hpp>).
//
//   pt::Simulation sim(pt::load_scenario("scenarios/start-inward.json"), {.threads = 2});
//   for (int i = 0; i < 10; ++i) sim.step();
//   std::span<const pt::Vec3> x = pt::positions(sim.sheet());   // engine/api.hpp: views, events
//
// Errors are exceptions (components/errors.hpp): pt::InputError ("<file>: <json path>: <problem>") for
// scenarios, pt::GeometryError for outlines or fingers the mesher cannot honour.
//
// Installed, this file is <prefix>/include/papertear/papertear.hpp beside engine/ and components/, so its
// "engine/..." includes resolve from here in both layouts; the headers under engine/ include their
// siblings by name and components/ as "../components/...". No installed header includes systems/.
#pragma once

#include "components/errors.hpp"
#include "components/sheet.hpp"
#include "engine/api.hpp"
#include "engine/batch.hpp"
#include "engine/result_writer.hpp"
#include "engine/scenario.hpp"
#include "engine/simulation.hpp"
#include "engine/version.hpp"
