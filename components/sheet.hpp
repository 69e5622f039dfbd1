// The sheet of paper as structure-of-arrays. Plain data only: systems/ computes, engine/ schedules.
//
// Invariants kept by every system that changes topology (meshing, remeshing), checked by
// systems/common/topology.hpp `check_mesh_invariants`:
//   - every array of Vertices has Vertices::size() entries, every array of Triangles has Triangles::size();
//   - triangle corners are valid vertex ids, counter-clockwise in the pattern (rest), positive rest area;
//   - each undirected edge is shared by at most two triangles; every vertex's triangle fan is connected
//     (no bow-tie vertex: a tear that touches a vertex duplicates it);
//   - Topology is derived from Triangles by `build_topology` and is rebuilt, or refreshed where a cut changed
//     it, after each topology change (its `version` equals Sheet::topology_version).
#pragma once

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace pt {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Mat2 = Eigen::Matrix2d;
using Mat3 = Eigen::Matrix3d;
using Tri = std::array<int32_t, 3>;

// Office paper, 80 g/m² (docs/physics.md). The tearing constants are calibrated so a trouser pull starts
// at 0.6–1.25 N per finger (docs/tearing.md): Er = (F_L + F_R) cos(θ/2) / e, Ef = c · T · d.
struct Material {
  double thickness = 1e-4;     // e, m
  double density = 800;        // kg/m³ (800 · 1e-4 = 80 g/m²)
  double young = 4e9;          // Pa
  double poisson = 0.3;
  double bending_scale = 1;    // multiplies E e³ / (12 (1 − ν²))
  // The membrane's effective in-plane modulus is membrane_scale · young up to a principal strain of
  // strain_limit, and young beyond it (docs/physics.md, "Membrane"): a coarse mesh of constant-strain
  // triangles cannot bend isometrically, and at paper's full stiffness the strains that locking leaves
  // (1e-4 .. 5e-3) would carry tens of newtons where paper carries millinewtons.
  double membrane_scale = 0.03;
  double strain_limit = 0.02;
  // Compression relief (docs/physics.md, "Membrane"): a compressed principal direction keeps
  // compression_scale of its stiffness, as paper wrinkled finer than the mesh carries little compression,
  // up to a principal strain of −compression_limit, beyond which it is as stiff as paper again. 1: off.
  double compression_scale = 0.05;
  double compression_limit = 0.05;
  double damping = 2.0;        // 1/s, mass-proportional velocity damping
  double tip_damage = 0.15;    // D of eq. 3, in [0,1]: a tip tears ~7x more easily than fresh paper
  uint64_t fiber_seed = 1;     // seed of T_fiber
  double fiber_scale = 0.004;  // m, feature size of the coarsest octave of T_fiber
  double fracture_c = 2.5e4;   // c of eq. 3, J/m² (Ef = c T d): a trouser pull starts at F = Ef e / 2 ≈ 0.6–1.25 N
  double fiber_floor = 0.5;    // T in eq. 3 is lifted onto [fiber_floor, 1] (0: eq. 3 exactly)
  double min_step = 0.002;     // m; shorter propagation steps are lengthened (no slivers)
  double speed = 2e-7;         // k of p_next = p + k Er t, m per (J/m²)
  double max_step = 0.01;      // cap on one propagation step, m
};

enum VertexFlag : uint8_t {
  kBoundary = 1 << 0,   // on the sheet's boundary (outline or a tear lip)
  kFinger = 1 << 1,     // a finger holds it
  kTip = 1 << 2,        // the tip of an active tear
  kJunction = 1 << 3,   // junction point of the geometric layer (docs/tearing.md)
  kNew = 1 << 4,        // created by the last remesh
  kInward = 1 << 5,     // boundary vertex with interior pattern angle > π
  kSingular = 1 << 6,   // interior singular point (bending concentrates)
};

// Per vertex. Hot (touched by every substep): x, v, force. Warm: rest, mass, flags, tear.
struct Vertices {
  std::vector<Vec3> x;        // 3D position, m
  std::vector<Vec3> v;        // velocity, m/s
  std::vector<Vec3> force;    // total internal force (membrane + bending) on the vertex, N
  std::vector<Vec2> rest;     // 2D pattern position (u, v), m
  std::vector<double> mass;   // lumped mass, kg (a third of each incident triangle's mass)
  std::vector<uint8_t> flags; // VertexFlag bits
  std::vector<int32_t> tear;  // id of the tear whose lip holds this vertex, −1 if none

  int32_t size() const { return static_cast<int32_t>(x.size()); }
  void resize(int32_t n) {
    x.resize(n, Vec3::Zero());
    v.resize(n, Vec3::Zero());
    force.resize(n, Vec3::Zero());
    rest.resize(n, Vec2::Zero());
    mass.resize(n, 0.0);
    flags.resize(n, 0);
    tear.resize(n, -1);
  }
  // Copies entry `from` over entry `to` in every array (swap-remove keeps the arrays dense).
  void copy_entry(int32_t from, int32_t to) {
    x[to] = x[from];
    v[to] = v[from];
    force[to] = force[from];
    rest[to] = rest[from];
    mass[to] = mass[from];
    flags[to] = flags[from];
    tear[to] = tear[from];
  }
};

// Per triangle. `corner_force[t][i]` is the membrane force triangle t applies to its corner i
// (written by the force system, read by clustering and the J-vector).
struct Triangles {
  std::vector<Tri> tri;                          // vertex ids, counter-clockwise in the pattern
  std::vector<Mat2> rest_inv;                    // inverse of [r1 − r0, r2 − r0] (pattern)
  std::vector<double> rest_area;                 // pattern area, m²
  std::vector<std::array<Vec3, 3>> corner_force; // membrane force on each corner, N
  std::vector<int32_t> region;                   // region id (regions system), −1 before it runs
  std::vector<int32_t> piece;                    // connected piece id (topology)
  std::vector<int32_t> side;                     // texture side label (carving), 0 = untouched
  // The fraction of the triangle's area between a finger's tips: the pinch presses the paper flat there, so
  // it cannot wrinkle and carries compression (docs/physics.md, "Compression relief"). Derived: the engine
  // writes it from its fingers (mark_pinched_triangles) before the physics reads it, so remeshing leaves it
  // alone; entries past its end count as 0.
  std::vector<double> pinched;

  int32_t size() const { return static_cast<int32_t>(tri.size()); }
  void resize(int32_t n) {
    tri.resize(n, Tri{0, 0, 0});
    rest_inv.resize(n, Mat2::Identity());
    rest_area.resize(n, 0.0);
    corner_force.resize(n, {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()});
    region.resize(n, -1);
    piece.resize(n, 0);
    side.resize(n, 0);
  }
  void copy_entry(int32_t from, int32_t to) {
    tri[to] = tri[from];
    rest_inv[to] = rest_inv[from];
    rest_area[to] = rest_area[from];
    corner_force[to] = corner_force[from];
    region[to] = region[from];
    piece[to] = piece[from];
    side[to] = side[from];
  }
};

// An interior edge (v0, v1) with its two opposite vertices: v2 on the triangle where v0→v1 is
// counter-clockwise, v3 on the other. Bending acts on hinges.
struct Hinge {
  std::array<int32_t, 4> v;
};

// Derived from Triangles by build_topology (systems/common/topology.hpp), kept up to date by the local refresh
// after a cut (refresh_after_local_change) in time that grows with the cut, not with the sheet (issue 3).
struct Topology {
  uint64_t version = ~uint64_t{0};
  // Fans: the triangles of vertex i are vt_tri[fans[i].offset .. fans[i].offset + fans[i].count), ascending
  // (see fan()). Each fan has room for fans[i].capacity ≥ count entries, so a cut rewrites the fans it changes
  // in place; a fan that outgrows its room moves to the end of vt_tri and leaves vt_unused entries behind
  // (the pool is compacted when they reach half of it). One record per vertex: a fan costs one cache line
  // to find, not three, when a cut comes back to a sheet whose physics step has evicted it.
  struct FanRoom {
    int32_t offset = 0, count = 0, capacity = 0;
  };
  std::vector<FanRoom> fans;
  std::vector<int32_t> vt_tri;
  int32_t vt_unused = 0;
  std::vector<std::array<int32_t, 3>> neighbor;  // neighbor[t][i]: triangle across edge (tri[i], tri[i+1]), −1 on the boundary
  std::vector<std::array<int32_t, 3>> edge_hinge;  // edge_hinge[t][i]: hinge on that edge, −1 on the boundary
  // Interior edges, each oriented from its lower triangle. build_topology lists them by (min, max) of the
  // edge; a local refresh puts a cut's new hinges in the slots of the ones it removed (then appends, or
  // fills holes from the end), so their order depends on the sheet's history, deterministically.
  std::vector<Hinge> hinges;
  std::vector<int32_t> boundary_next;            // along the boundary, interior on the left; −1 if interior vertex
  std::vector<int32_t> boundary_prev;
  std::vector<int32_t> boundary_vertices;        // those with boundary_next ≥ 0, ascending (the candidates' scan)
  int32_t piece_count = 0;

  std::span<const int32_t> fan(int32_t v) const {
    return {vt_tri.data() + fans[v].offset, static_cast<size_t>(fans[v].count)};
  }
  int32_t vertex_count() const { return static_cast<int32_t>(fans.size()); }
};

enum class RegionKind : uint8_t { Flat = 0, CurvedPositive = 1, CurvedNegative = 2 };

struct Region {
  RegionKind kind = RegionKind::Flat;
  int32_t triangle_count = 0;
  int32_t apex = -1;  // interior singular vertex (cone apex) if any
};

enum class StartKind : uint8_t { Finger = 0, Junction = 1, Inward = 2 };

// A tear: stable id, never removed. `tips` is the coarse path in the pattern (the first is the start
// point), `detail` the fine path of the carving system (paper §6).
struct Tear {
  int32_t id = -1;
  int32_t parent = -1;
  StartKind start_kind = StartKind::Inward;
  int32_t start_frame = 0;
  Vec2 start_uv = Vec2::Zero();
  std::vector<Vec2> tips;
  std::vector<Vec2> detail;
  int32_t carved_segments = 0;  // segments of `tips` already carved into `detail`
  bool reached_boundary = false;
  // How far the tear grew within one frame (pattern path length, m): its largest such advance, and the
  // frame being summed. Hands tear paper at their own pace; a tear that outruns them ran away.
  double max_frame_advance = 0;
  double frame_advance = 0;
  int32_t advance_frame = -1;
};

// What happened to a tear at a frame, in the order the tearing step did it (TearStarted or TearExtended
// for each segment, then PieceSeparated when that segment split the sheet).
struct TearEvent {
  enum Kind { TearStarted, TearExtended, PieceSeparated } kind;
  int32_t tear = -1;
  int32_t frame = 0;
};

// The active tip of a tear: the vertex where it continues. Removed when the tear reaches the boundary.
struct Tip {
  int32_t vertex = -1;
  int32_t tear = -1;
  Vec2 direction = Vec2::Zero();  // direction of the last segment in the pattern (unit), zero if none
};

// How a finger's or a hand's keys are joined in time (docs/scenario-format.md, "interpolation"): at
// constant speed from key to key, or by a monotone cubic that starts and ends at rest (systems/physics/fingers.hpp).
enum class KeyInterpolation : uint8_t { linear, smooth };

struct FingerKey {
  double t = 0;                 // s
  Vec3 position = Vec3::Zero(); // world, m
};

struct HandKey {
  double t = 0;
  Vec3 translate = Vec3::Zero();
  double rotate_deg = 0;
  Vec3 axis = Vec3(0, 0, 1);
};

struct Finger {
  std::string name;
  Vec2 uv = Vec2::Zero();        // where it was put, pattern
  int32_t vertex = -1;           // the vertex it holds (−1 when released)
  std::vector<FingerKey> keys;
  KeyInterpolation interpolation = KeyInterpolation::linear;
  int32_t hand = -1;
  Vec3 start = Vec3::Zero();     // world position when put (z = 0 on the flat sheet)
  Vec3 target = Vec3::Zero();    // prescribed position now
  Vec3 reaction = Vec3::Zero();  // force the finger applies to the sheet now, N
  double max_force = 0;          // max |reaction| so far, N
  double attach_time = 0;        // s: the finger is put on the sheet then (a vertex is inserted at uv)
  double release_time = 1e300;   // s: and lets go then
  bool released = false;
  // A pinch holds up to its grip; beyond it the paper slides through the finger (systems/physics/grip.hpp)
  // until the next frame, when it pinches again where the paper is, hold_offset away from its own point.
  double grip = 15;              // N, a firm pinch
  double reach = 0.02;           // m: the paper has slid out of the pinch once hold_offset is longer
  bool slipping = false;
  bool let_go = false;           // the paper slid out of the pinch (released, not by the scenario)
  int32_t slips = 0;             // times the grip was exceeded
  Vec3 hold_offset = Vec3::Zero();  // where the held vertex is kept relative to target, m
  // A pad (systems/physics/fingers.hpp, "pads"): the vertices within pad_radius of uv, held rigidly with the
  // finger and turned with its hand. pad_offset[j] is pad[j]'s offset from `vertex` in the hand's frame.
  double pad_radius = 0;         // m; 0: the finger holds its vertex only
  std::vector<int32_t> pad;
  std::vector<Vec3> pad_offset;
};

struct Hand {
  std::string name;
  std::vector<int32_t> fingers;
  std::vector<HandKey> keys;
  KeyInterpolation interpolation = KeyInterpolation::linear;
  Vec3 centroid = Vec3::Zero();  // of where its fingers hold: their starts (hand_centroid_of_starts)
};

struct Sheet {
  Material material;
  Vertices verts;
  Triangles tris;
  Topology topo;
  std::vector<Region> regions;
  std::vector<Tear> tears;   // index == id
  std::vector<Tip> tips;     // active tips
  std::vector<Finger> fingers;
  std::vector<Hand> hands;
  uint64_t topology_version = 0;  // bumped by every topology change
};

}  // namespace pt
