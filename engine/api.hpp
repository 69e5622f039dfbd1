// Embedding API (issue 8): read-only views of a sheet without copies, and a cursor over the engine's
// events. Header-only; everything here is a thin layer over pt::Simulation and pt::Sheet.
//
// Lifetime: a view points into the sheet's arrays. It stays valid (and follows the simulation: after
// step() it shows the new positions) until the topology changes — a tear cut, a remesh or a finger
// attached inserts vertices and may reallocate the arrays. Sheet::topology_version changes exactly then;
// take new views when it does. (The engine only grows these vectors with push_back/resize, so a tool of
// this repository that needs views to outlive growth can reserve() capacity through mutable_sheet() of
// engine/simulation_internals.hpp between frames, as the Python module does.)
#pragma once

#include "../components/sheet.hpp"
#include "simulation.hpp"

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace pt {

static_assert(sizeof(Vec3) == 3 * sizeof(double), "Vec3 must be three packed doubles");
static_assert(sizeof(Vec2) == 2 * sizeof(double), "Vec2 must be two packed doubles");
static_assert(sizeof(Tri) == 3 * sizeof(int32_t), "Tri must be three packed int32");

// Per vertex: 3D position (m) and 2D pattern coordinates (m).
inline std::span<const Vec3> positions(const Sheet& s) { return s.verts.x; }
inline std::span<const Vec2> pattern(const Sheet& s) { return s.verts.rest; }
// Per triangle: vertex ids (counter-clockwise in the pattern) and connected piece id.
inline std::span<const Tri> triangles(const Sheet& s) { return s.tris.tri; }
inline std::span<const int32_t> triangle_pieces(const Sheet& s) { return s.tris.piece; }
inline std::span<const Tear> tears(const Sheet& s) { return s.tears; }
inline int32_t piece_count(const Sheet& s) { return s.topo.piece_count; }

// The same arrays as flat scalars (x0 y0 z0 x1 ...), e.g. for a GPU upload or a foreign array type.
inline std::span<const double> positions_flat(const Sheet& s) {
  return {s.verts.x.empty() ? nullptr : s.verts.x.front().data(), s.verts.x.size() * 3};
}
inline std::span<const double> pattern_flat(const Sheet& s) {
  return {s.verts.rest.empty() ? nullptr : s.verts.rest.front().data(), s.verts.rest.size() * 2};
}
inline std::span<const int32_t> triangles_flat(const Sheet& s) {
  return {s.tris.tri.empty() ? nullptr : s.tris.tri.front().data(), s.tris.tri.size() * 3};
}

// "Tell me when a tear starts or a piece separates": keep one cursor per listener and ask it for the
// events since its last call after each step().
//
//   pt::EventCursor events;
//   sim.step();
//   for (const pt::TearEvent& e : events.next(sim))
//     if (e.kind == pt::TearEvent::PieceSeparated) ...
class EventCursor {
 public:
  std::span<const TearEvent> next(const Simulation& sim) {
    const std::vector<TearEvent>& all = sim.events();
    const size_t from = seen_ < all.size() ? seen_ : all.size();
    seen_ = all.size();
    return std::span<const TearEvent>(all).subspan(from);
  }
  size_t seen() const { return seen_; }

 private:
  size_t seen_ = 0;
};

inline const char* to_string(TearEvent::Kind k) {
  switch (k) {
    case TearEvent::TearStarted: return "tear_started";
    case TearEvent::TearExtended: return "tear_extended";
    case TearEvent::PieceSeparated: return "piece_separated";
  }
  return "unknown";
}

inline const char* to_string(StartKind k) {
  switch (k) {
    case StartKind::Finger: return "finger";
    case StartKind::Junction: return "junction";
    case StartKind::Inward: return "inward";
  }
  return "unknown";
}

}  // namespace pt
