// Builds a Sheet from a scenario: meshing with a vertex at every finger point, fingers, hands,
// material; and the fiber field over the outline's bounding box (the texture frame,
// docs/architecture.md "Details").
#pragma once

#include "components/sheet.hpp"
#include "engine/scenario.hpp"
#include "systems/tearing/fiber_field.hpp"

namespace pt {

// Throws GeometryError (systems/mesh/meshing.hpp) on an outline or finger the mesher cannot honour.
Sheet build_sheet(const Scenario& scenario);

// The fiber field and texture frame of a scenario: origin at the outline's bounding-box minimum, pixel
// size from detail.texture (or 0.1 mm when unset).
FiberField make_fiber_field(const Scenario& scenario);

// Texture size in pixels [width, height] (detail.texture, or the bounding box at 0.1 mm per pixel).
std::array<int32_t, 2> texture_size(const Scenario& scenario);

}  // namespace pt
