// How far a tear's coarse path is from the paths the paper's figures claim (docs/tearing.md "Measured"):
// the mediator of two fingers (Fig. 14), O'Keefe's direction at each step, and the direction changes of a
// zigzag (Fig. 16). Shared by the scenario tests (tests/engine/scenarios_test.cpp) and the 16-mesh harness
// (tools/path_claims.cpp), so both measure the same thing.
#pragma once

#include "components/sheet.hpp"
#include "engine/scenario.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace pt::path_claims {

// Pattern point of the scenario's finger `name`; std::invalid_argument when it has none of that name.
inline Vec2 finger_uv(const Scenario& s, const std::string& name) {
  for (const FingerSpec& f : s.fingers)
    if (f.name == name) return f.at;
  throw std::invalid_argument(s.name + ": no finger " + name);
}

// Largest distance of the first tear's coarse path from the mediator of fingers A and B, as a fraction of
// the path's length; with `within`, over the tips up to that path length only.
inline double mediator_error(const Scenario& s, const Sheet& sheet, double within = 1e300) {
  const Vec2 a = finger_uv(s, "A"), b = finger_uv(s, "B"), axis = (b - a).normalized(), mid = 0.5 * (a + b);
  const Tear& tear = sheet.tears.at(0);
  double worst = 0, length = 0;
  for (size_t i = 0; i < tear.tips.size(); ++i) {
    const double step = i > 0 ? (tear.tips[i] - tear.tips[i - 1]).norm() : 0.0;
    if (length + step > within) break;
    length += step;
    worst = std::max(worst, std::abs((tear.tips[i] - mid).dot(axis)));
  }
  return length > 0 ? worst / length : 0.0;
}

// Sign changes of the turn between consecutive coarse segments, ignoring turns below `threshold`.
inline int direction_changes(const std::vector<Vec2>& tips, double threshold) {
  int changes = 0, last_sign = 0;
  for (size_t i = 2; i < tips.size(); ++i) {
    const Vec2 a = tips[i - 1] - tips[i - 2], b = tips[i] - tips[i - 1];
    const double turn = std::atan2(a.x() * b.y() - a.y() * b.x(), a.dot(b));
    if (std::abs(turn) < threshold) continue;
    const int sign = turn > 0 ? 1 : -1;
    if (last_sign != 0 && sign != last_sign) ++changes;
    last_sign = sign;
  }
  return changes;
}

// The angle (radians) between each coarse step of tear 0 and O'Keefe's direction at its start P: away
// from the fingers, along the bisector of PA and PB (docs/tearing.md; the tangent of the
// hyperbola through P). A step's own error, so it does not add up along the path as the distances do.
inline std::vector<double> okeefe_step_errors(const Scenario& s, const Sheet& sheet) {
  const Vec2 a = finger_uv(s, "A"), b = finger_uv(s, "B");
  const std::vector<Vec2>& tips = sheet.tears.at(0).tips;
  std::vector<double> errors;
  for (size_t i = 1; i < tips.size(); ++i) {
    const Vec2 p = tips[i - 1], step = tips[i] - p;
    const Vec2 okeefe = -((a - p).normalized() + (b - p).normalized());
    errors.push_back(std::atan2(std::abs(okeefe.x() * step.y() - okeefe.y() * step.x()), okeefe.dot(step)));
  }
  return errors;
}

}  // namespace pt::path_claims
