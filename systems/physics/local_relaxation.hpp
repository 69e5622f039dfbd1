// The relaxation after a propagation (paper Fig. 4, step 4), restricted to a patch of the sheet around
// the cut: "sim": {"relaxation": "patch"}.
//
// Why: the paper relaxes the whole sheet for one physics step after each cut, so that the lips move apart
// before the next potential tearing point is treated. With the implicit integrator that step is a whole
// factorisation of the sheet's matrix, after a new symbolic analysis (the cut changed the mesh): at
// 10 000 triangles and one substep per frame it is a third of the frame's time (README, issue 6). What the
// step changes is local: the cut frees the lips' vertices of the stress they carried, and they move apart
// while the far sheet, in balance before the cut, barely notices within one substep. So the same implicit
// substep (systems/physics/integrate_implicit.hpp) is solved on a copy of the sheet's triangles near the cut, with
// the vertices at the patch's rim held where they are, and the patch's vertices are written back. The
// system then has a few hundred vertices whatever the sheet's size.
//
// The patch's free vertices are those within `radius` of the tear's path in the pattern (all its
// segments: the full step opens the whole crack a little more when it grows, not only its new segment),
// and every vertex the last remesh created (kNew) with its one-ring. Its triangles are the fans of the free
// vertices and their neighbours across an edge, so every triangle and hinge (bending stencil) that moves a
// free vertex is in the copy whole. Vertices of those triangles that are not free are held at their
// positions, so the patch's step is the full step's on its free vertices with the rest of the sheet
// standing still: with a radius that covers the sheet, it is the full substep (the unit test checks it to
// 10⁻¹² m). Fingers inside the patch are held at their targets, as in the full step.
//
// What it costs in fidelity (bench/results/2026-11-23-10-notes.txt): the full substep is nearly
// quasi-static (h²K ≫ M), so it opens a crack along its whole length and spreads the released stress over
// the sheet; the patch opens the lips less (0.37 of the full step's opening at 3 cm in the unit test's
// stretched sheet) and its held rim keeps some stress. On Figs. 14–16 over 16 meshes the paths and tear
// counts are within the default's scatter; under a heavy pull (torn-in-two.json, ~80 N) it starts more
// tears (8.2 against 5.6 per sheet). Hence an option, not the default.
#pragma once

#include "components/sheet.hpp"
#include "systems/physics/integrate_implicit.hpp"

#include <span>
#include <vector>

namespace pt {

struct LocalRelaxationParams {
  double radius = 0.03;  // m, pattern distance from the tear's path within which vertices move
};

// What the step keeps between calls (reused storage; nothing in it carries over as state).
struct LocalRelaxationScratch {
  Sheet patch;                          // the copy: its vertices and triangles, topology built from them
  std::vector<int32_t> sheet_vertex;    // patch vertex → sheet vertex
  std::vector<int32_t> patch_vertex;    // sheet vertex → patch vertex, −1 outside (all −1 between calls)
  std::vector<uint8_t> free;            // per patch vertex: moves in the step
  std::vector<int32_t> free_list;       // sheet ids of the free vertices, ascending
  std::vector<int32_t> triangles;       // sheet ids of the copy's triangles, ascending
  std::vector<int32_t> triangle_stamp;  // per sheet triangle: last call that took it (dedup)
  int32_t stamp = 0;
  std::vector<int32_t> held;            // the copy's held vertices (rim ascending, then free fingers)
  std::vector<Vec3> held_target;
  std::vector<int32_t> piece;  // build_topology's piece labels of the copy (not read)
};

struct LocalRelaxationResult {
  bool relaxed = false;        // false: the implicit step refused (the sheet is unchanged)
  int32_t free_vertices = 0;   // vertices that moved
  int32_t triangles = 0;       // triangles of the copy
};

// One implicit substep of the patch around `path` (the tear's coarse path in the pattern, its new segment
// last; a single point is a disc). `held` / `held_target`
// are the sheet's prescribed vertices (fingers) and where they are held, as for implicit_substep. Writes x
// and v of the patch's free vertices; every other vertex, and the rest of the sheet, is left unchanged.
LocalRelaxationResult relax_patch_after_cut(const ImplicitParams& params, const LocalRelaxationParams& local,
                                            std::span<const Vec2> path, const std::vector<int32_t>& held,
                                            const std::vector<Vec3>& held_target, LocalRelaxationScratch& scratch,
                                            Sheet& sheet);

}  // namespace pt
