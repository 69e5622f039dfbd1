// Shortest paths inside one piece of the torn pattern (rest positions), for the tension rays
// (systems/tearing/tension_rays.hpp). The domain is bounded by the piece's boundary edges: the outline and
// the tear lips (a cut duplicates vertices, so each lip is a boundary edge chain of its own). A shortest
// path is straight where it can be and otherwise bends only at reflex boundary vertices (interior angle
// > π: tear tips, notch corners), so it is found by Dijkstra over the visibility graph of the source,
// the targets and the reflex vertices (Lozano-Pérez & Wesley 1979).
#pragma once

#include "components/sheet.hpp"

#include <span>
#include <vector>

namespace pt {

struct PatternPathParams {
  // Lengths below relative_tolerance · (size of the piece's bounding box) count as zero: a point that
  // close to a line is on it, so collinear and touching cases are decided one way, whatever the rounding.
  double relative_tolerance = 1e-9;
  double angle_tolerance = 1e-9;  // rad: a direction this close to a boundary direction at a vertex is along it
};

// The boundary edges of one piece, bucketed in a uniform grid (about one edge per cell) so a segment
// test visits the cells along the segment, not every edge.
struct PatternBoundary {
  int32_t piece = -1;
  std::vector<int32_t> edges;   // start vertex v of each boundary edge v → boundary_next[v], ascending
  std::vector<int32_t> reflex;  // boundary vertices with interior angle > π + angle_tolerance, ascending
  Vec2 origin = Vec2::Zero();   // lower corner of the grid
  double cell = 1;              // cell side, m
  int32_t nx = 1, ny = 1;
  std::vector<int32_t> cell_start;  // edges of cell c: cell_edges[cell_start[c] .. cell_start[c + 1])
  std::vector<int32_t> cell_edges;  // indices into `edges`
  double tolerance = 0;             // absolute length tolerance, m
  double angle_tolerance = 0;
};

// Per query: which edges a segment test has already looked at (edges are listed in several cells).
struct SegmentQueryScratch {
  std::vector<uint32_t> stamp;  // per entry of PatternBoundary::edges
  uint32_t query = 0;
};

// Piece of vertex v: the piece of a triangle of its fan (fans are connected), −1 for an isolated vertex.
int32_t vertex_piece(const Topology& topo, const std::vector<int32_t>& piece, int32_t v);

// The boundary of piece `piece_id`. Reuses the vectors of `out` (no allocation once they are large enough).
void build_pattern_boundary(const Topology& topo, const std::vector<Vec2>& rest, const std::vector<int32_t>& piece,
                            int32_t piece_id, const PatternPathParams& params, PatternBoundary& out);

// True when the segment a → b lies in the closed domain of the piece: it crosses no boundary edge, and
// at every boundary vertex it passes through (collinear cases) and at its ends a_vertex and b_vertex
// (when ≥ 0, boundary vertices at a and b; −1 for points inside the piece) it stays within the
// vertex's interior angle. Running along the boundary and touching it is allowed. Distinct vertices
// at the same position (the two copies of a lip vertex) are not joined: zero-length segments are false.
bool segment_in_pattern(const PatternBoundary& boundary, const Topology& topo, const std::vector<Vec2>& rest,
                        const Vec2& a, int32_t a_vertex, const Vec2& b, int32_t b_vertex,
                        SegmentQueryScratch& scratch);

struct PatternPath {
  bool reachable = false;
  bool straight = false;           // the segment source → target lies in the domain
  double length = 0;               // m
  Vec2 first_direction = Vec2::Zero();  // unit direction of the first segment at the source
  int32_t first_corner = -1;       // the reflex vertex where the path first bends, −1 when straight
  int32_t point_begin = 0, point_end = 0;  // its corners then the target: PatternPaths::points[begin, end)
};

struct PatternPaths {
  std::vector<PatternPath> paths;  // one per target, in order
  std::vector<Vec2> points;        // the paths' points after the source
  std::vector<int32_t> point_vertex;  // the vertex of each point (the target's vertex for the last one)
  int32_t visibility_tests = 0;    // segment tests made (cost)
};

struct PatternPathScratch {
  SegmentQueryScratch query;
  std::vector<int32_t> node_vertex;  // nodes: source, targets, reflex vertices
  std::vector<double> distance;
  std::vector<int32_t> previous;
  std::vector<uint8_t> done;
  std::vector<int32_t> chain;
};

// Shortest paths in `boundary`'s piece from vertex `source` (a boundary vertex, or an interior one such as a
// finger's) to each vertex of `targets`
// (interior or boundary vertices of the same piece). Deterministic: nodes are taken in a fixed order
// (source, targets, reflex vertices ascending) and ties go to the lower node. A target at the source's
// position (another copy of it) is reached around the tear, never directly.
void shortest_pattern_paths(const PatternBoundary& boundary, const Topology& topo, const std::vector<Vec2>& rest,
                            int32_t source, std::span<const int32_t> targets, PatternPathScratch& scratch,
                            PatternPaths& out);

}  // namespace pt
