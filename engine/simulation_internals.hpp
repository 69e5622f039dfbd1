// What a Simulation keeps besides its public state, for the apps, tools, tests and the Python module of this
// repository: the carving, the fibre field, the last frame's candidates, the implicit solver's counts and
// the sheet to edit in place. Not installed: these are systems' types, which an embedding program does not
// see (engine/simulation.hpp names none of them).
#pragma once

#include "engine/simulation.hpp"
#include "systems/tearing/candidates.hpp"
#include "systems/carving/carving.hpp"
#include "systems/tearing/fiber_field.hpp"
#include "systems/physics/integrate_implicit.hpp"
#include "systems/physics/self_contact.hpp"

#include <functional>

#include <vector>

namespace pt {

const FiberField& fiber_field(const Simulation& sim);
const DetailParams& detail_params(const Simulation& sim);
const CarveState& carve_state(const Simulation& sim);
// Potential tearing points of the last frame.
const std::vector<Candidate>& tearing_candidates(const Simulation& sim);
// Counts of the implicit integrator so far: symbolic
// analyses (after cuts or a change of the held set), numeric factorisations, spin-brake redos, failures.
ImplicitStats solver_stats(const Simulation& sim);
// For tools that move fingers or change the material by hand; call sim.notify_topology_changed() after
// edits of the mesh.
Sheet& mutable_sheet(Simulation& sim);
// The self-contact pass's counts so far, or null when the scenario has it off.
const SelfContactStats* self_contact_stats(const Simulation& sim);
// Called with the sheet after every substep of the frames' physics and the relaxations after cuts (tests:
// the state every substep reaches).
void set_substep_observer(Simulation& sim, std::function<void(const Sheet&)> observer);

}  // namespace pt
