#include "state/transform.h"

#include <cmath>
#include <cstring>
#include <vector>

namespace cdsm::editor {
namespace {

constexpr double kDeg = 180.0 / 3.14159265358979323846;

bool same_bits(const Mat4& a, const Mat4& b) { return std::memcmp(&a, &b, sizeof(Mat4)) == 0; }

// Six values a search varies: rotation (degrees) then scale.
struct Values {
  double v[6];
  Trs trs(const Vec3& translate) const {
    Trs t;
    t.translate = translate;
    t.rotate_deg = {float(v[0]), float(v[1]), float(v[2])};
    t.scale = {float(v[3]), float(v[4]), float(v[5])};
    return t;
  }
};

double wrap180(double a) {
  while (a > 180.0) a -= 360.0;
  while (a <= -180.0) a += 360.0;
  return a;
}

double round_to(double x, int decimals) {
  const double p = std::pow(10.0, decimals);
  const double r = std::round(x * p) / p;
  return r == 0.0 ? 0.0 : r;  // no negative zero
}

// The analytic decomposition with the signs of the scales given (their
// product must match the determinant's sign) and one of the two Euler
// solutions.
Values solve(const Mat4& m, const int sign[3], bool second) {
  double col[3][3];
  double scale[3];
  for (int j = 0; j < 3; ++j) {
    double len = 0.0;
    for (int i = 0; i < 3; ++i) len += double(m.m[i][j]) * double(m.m[i][j]);
    scale[j] = std::sqrt(len) * sign[j];
    for (int i = 0; i < 3; ++i) col[j][i] = scale[j] != 0.0 ? double(m.m[i][j]) / scale[j] : (i == j ? 1.0 : 0.0);
  }
  auto R = [&](int i, int j) { return col[j][i]; };
  // R = Rz Ry Rx: R20 = -sin y, R21 = cos y sin x, R22 = cos y cos x,
  // R10 = cos y sin z, R00 = cos y cos z.
  const double cy = std::hypot(R(0, 0), R(1, 0));
  double x, y, z;
  if (cy > 1e-6) {
    y = std::atan2(-R(2, 0), cy);
    x = std::atan2(R(2, 1), R(2, 2));
    z = std::atan2(R(1, 0), R(0, 0));
    if (second) {  // the other solution: (x + 180, 180 - y, z + 180)
      y = std::atan2(-R(2, 0), -cy);
      x = std::atan2(-R(2, 1), -R(2, 2));
      z = std::atan2(-R(1, 0), -R(0, 0));
    }
  } else {  // gimbal lock: y = +-90, the rotation about X folded into Z
    y = R(2, 0) < 0 ? 3.14159265358979323846 / 2 : -3.14159265358979323846 / 2;
    x = 0.0;
    z = std::atan2(-R(0, 1), R(1, 1));
  }
  return {{wrap180(x * kDeg), wrap180(y * kDeg), wrap180(z * kDeg), scale[0], scale[1], scale[2]}};
}

}  // namespace

Mat4 compose(const Trs& t) { return make_transform(t.translate, t.rotate_deg, t.scale); }

namespace {

// Every answer for m: per sign pattern and Euler solution, the shortest
// decimals that compose to m exactly (exact = true), else the analytic
// values. In order of preference (fewest negative scales, first solution).
struct Answer {
  Values values;
  bool exact = false;
};

std::vector<Answer> answers(const Mat4& m, const Vec3& translate, bool first_exact_only) {
  std::vector<Answer> out;
  const bool mirrored = det3(m) < 0.0f;
  // Sign patterns of the scales: as few negative as the determinant allows.
  static const int kPositive[4][3] = {{1, 1, 1}, {-1, -1, 1}, {-1, 1, -1}, {1, -1, -1}};
  static const int kMirrored[4][3] = {{-1, 1, 1}, {1, -1, 1}, {1, 1, -1}, {-1, -1, -1}};
  const int(*signs)[3] = mirrored ? kMirrored : kPositive;
  for (int s = 0; s < 4; ++s)
    for (int second = 0; second < 2; ++second) {
      const Values raw = solve(m, signs[s], second == 1);
      Answer a{raw, false};
      // The coarsest decimals, all values alike, that compose to m ...
      for (int d = 0; d <= 6 && !a.exact; ++d) {
        Values c = raw;
        for (double& x : c.v) x = round_to(x, d);
        if (!same_bits(compose(c.trs(translate)), m)) continue;
        // ... then each value as short as it can be on its own.
        for (int k = 0; k < 6; ++k)
          for (int e = 0; e < d; ++e) {
            Values shorter = c;
            shorter.v[k] = round_to(raw.v[k], e);
            if (same_bits(compose(shorter.trs(translate)), m)) {
              c = shorter;
              break;
            }
          }
        a = {c, true};
      }
      if (!a.exact) a.exact = same_bits(compose(raw.trs(translate)), m);
      out.push_back(a);
      if (a.exact && first_exact_only) return out;
    }
  return out;
}

double distance(const Values& a, const Trs& b) {
  const double hint[6] = {b.rotate_deg.x, b.rotate_deg.y, b.rotate_deg.z, b.scale.x, b.scale.y, b.scale.z};
  double d = 0.0;
  for (int k = 0; k < 6; ++k) {
    const double diff = k < 3 ? wrap180(a.v[k] - hint[k]) : a.v[k] - hint[k];
    d += diff * diff;
  }
  return d;
}

}  // namespace

Trs decompose(const Mat4& m) {
  const Vec3 translate{m.m[0][3], m.m[1][3], m.m[2][3]};
  const std::vector<Answer> all = answers(m, translate, true);
  if (all.back().exact) return all.back().values.trs(translate);
  return all.front().values.trs(translate);
}

Trs decompose(const Mat4& m, const Trs& near) {
  const Vec3 translate{m.m[0][3], m.m[1][3], m.m[2][3]};
  const std::vector<Answer> all = answers(m, translate, false);
  bool any_exact = false;
  for (const Answer& a : all) any_exact |= a.exact;
  const Answer* best = nullptr;
  for (const Answer& a : all)
    if ((a.exact || !any_exact) && (!best || distance(a.values, near) < distance(best->values, near))) best = &a;
  Trs t = best->values.trs(translate);
  // Angles as close to the hint as whole turns allow (the same matrix).
  for (int k = 0; k < 3; ++k) {
    float& a = k == 0 ? t.rotate_deg.x : k == 1 ? t.rotate_deg.y : t.rotate_deg.z;
    const float h = k == 0 ? near.rotate_deg.x : k == 1 ? near.rotate_deg.y : near.rotate_deg.z;
    Trs turned = t;
    float& b = k == 0 ? turned.rotate_deg.x : k == 1 ? turned.rotate_deg.y : turned.rotate_deg.z;
    b = a + 360.0f * std::round((h - a) / 360.0f);
    if (b != a && same_bits(compose(turned), m)) a = b;
  }
  return t;
}

}  // namespace cdsm::editor
