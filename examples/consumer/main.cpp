#include <papertear/papertear.hpp>

#include <iostream>

int main(int argc, char** argv) try {
  pt::Simulation sim(pt::load_scenario(argc > 1 ? argv[1] : "scenarios/start-inward.json"), {.threads = 2});
  pt::EventCursor events;
  for (int frame = 0; frame < 10; ++frame) {
    sim.step();
    for (const pt::TearEvent& e : events.next(sim))
      if (e.kind != pt::TearEvent::TearExtended)
        std::cout << "frame " << e.frame << ": " << pt::to_string(e.kind) << " (tear " << e.tear << ")\n";
  }
  std::span<const pt::Vec3> x = pt::positions(sim.sheet());  // no copy
  std::cout << "vertices " << x.size() << ", first at z = " << x[0].z() << "\n"
            << "tears " << sim.sheet().tears.size() << ", pieces " << pt::piece_count(sim.sheet()) << "\n"
            << "hash " << sim.state_hash() << "\n";
} catch (const pt::InputError& e) {  // "<file>: <json path>: <problem>"
  std::cerr << e.what() << "\n";
  return 2;
}
