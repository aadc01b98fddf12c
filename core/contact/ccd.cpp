#include "core/contact/ccd.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace goo::ccd {
namespace {

double clamp01(double x) {
  return std::clamp(x, 0.0, 1.0);
}

/// The rate at which the closest points approach (negative) or separate.
double approach_rate(PairKind kind, const Points4& x, const Points4& d) {
  const Closest c = closest(kind, x);
  Vec3 gap = Vec3::Zero(), rate = Vec3::Zero();
  for (std::size_t k = 0; k < 4; ++k) {
    gap += c.coefficients[k] * x[k];
    rate += c.coefficients[k] * d[k];
  }
  const double n = gap.norm();
  return n > 0.0 ? rate.dot(gap) / n : -rate.norm();
}

}  // namespace

double point_triangle_distance2(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, Vec3* weights) {
  Vec3 w;
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  const double vc = d1 * d4 - d3 * d2, vb = d5 * d2 - d1 * d6, va = d3 * d6 - d5 * d4;
  if (d1 <= 0.0 && d2 <= 0.0) {
    w = {1, 0, 0};
  } else if (d3 >= 0.0 && d4 <= d3) {
    w = {0, 1, 0};
  } else if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    const double v = d1 / (d1 - d3);
    w = {1 - v, v, 0};
  } else if (d6 >= 0.0 && d5 <= d6) {
    w = {0, 0, 1};
  } else if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    const double v = d2 / (d2 - d6);
    w = {1 - v, 0, v};
  } else if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    const double v = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    w = {0, 1 - v, v};
  } else {
    const double denominator = va + vb + vc;
    const double v = vb / denominator, u = vc / denominator;
    w = {1 - v - u, v, u};
  }
  if (!w.allFinite()) {
    // No area: the nearest of the three edges.
    double s = 0.0, unused = 0.0, best = std::numeric_limits<double>::infinity();
    const std::array<std::array<int, 2>, 3> edges{{{0, 1}, {1, 2}, {2, 0}}};
    const std::array<const Vec3*, 3> q{&a, &b, &c};
    for (const auto& e : edges) {
      const double d = segment_segment_distance2(p, p, *q[std::size_t(e[0])], *q[std::size_t(e[1])], &unused, &s);
      if (d < best) {
        best = d;
        w.setZero();
        w[e[0]] = 1 - s;
        w[e[1]] = s;
      }
    }
  }
  if (weights) *weights = w;
  return (p - (w[0] * a + w[1] * b + w[2] * c)).squaredNorm();
}

double segment_segment_distance2(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1, double* s_out,
                                 double* u_out) {
  const Vec3 d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  double s = 0.0, u = 0.0;
  if (a == 0.0 && e == 0.0) {
    // two points
  } else if (a == 0.0) {
    u = clamp01(f / e);
  } else {
    const double c = d1.dot(r);
    if (e == 0.0) {
      s = clamp01(-c / a);
    } else {
      const double b = d1.dot(d2), denominator = a * e - b * b;
      s = denominator > 0.0 ? clamp01((b * f - c * e) / denominator) : 0.0;
      u = (b * s + f) / e;
      if (u < 0.0) {
        u = 0.0;
        s = clamp01(-c / a);
      } else if (u > 1.0) {
        u = 1.0;
        s = clamp01((b - c) / a);
      }
    }
  }
  if (s_out) *s_out = s;
  if (u_out) *u_out = u;
  return (p0 + s * d1 - (q0 + u * d2)).squaredNorm();
}

Closest closest(PairKind kind, const Points4& x) {
  Closest c;
  if (kind == PairKind::vertex_triangle) {
    Vec3 w;
    c.distance = std::sqrt(point_triangle_distance2(x[0], x[1], x[2], x[3], &w));
    c.coefficients = {1.0, -w[0], -w[1], -w[2]};
  } else {
    double s = 0.0, u = 0.0;
    c.distance = std::sqrt(segment_segment_distance2(x[0], x[1], x[2], x[3], &s, &u));
    c.coefficients = {1.0 - s, s, -(1.0 - u), -u};
  }
  return c;
}

std::optional<double> time_of_impact(PairKind kind, const Points4& x, const Points4& d_in, double min_distance,
                                     double* clearance) {
  constexpr double kUnknown = -std::numeric_limits<double>::infinity();
  if (clearance) *clearance = kUnknown;
  // Relative motion only: take out the mean displacement.
  Points4 d = d_in;
  const Vec3 mean = (d[0] + d[1] + d[2] + d[3]) / 4.0;
  for (Vec3& v : d) v -= mean;
  const double lp = kind == PairKind::vertex_triangle
                        ? d[0].norm() + std::max({d[1].norm(), d[2].norm(), d[3].norm()})
                        : std::max(d[0].norm(), d[1].norm()) + std::max(d[2].norm(), d[3].norm());
  double gap_now = closest(kind, x).distance - min_distance;
  if (gap_now <= 0.0) return 0.0;
  if (lp == 0.0) {  // no relative motion: the distance stays
    if (clearance) *clearance = gap_now - min_distance;
    return std::nullopt;
  }
  constexpr double kStep = 0.9;        // the fraction of the safe step taken
  constexpr int kMaxIterations = 10000;
  // Reported within min_distance of contact (or, when that is tiny against
  // the gap, within a tenth of the gap), approaching: there the line of the
  // closest points is the contact normal an impulse needs.
  double stop_gap = std::min((1.0 - kStep) * gap_now, min_distance);
  double smallest_gap = gap_now;  // over the steps taken: the distance stays above min_distance + (1 − s) of it
  double t = 0.0;
  Points4 xt = x;
  for (int iteration = 0; iteration < kMaxIterations; ++iteration) {
    const double t_next = t + kStep * gap_now / lp;
    if (t_next >= 1.0) {  // the safe step covers the rest of [0, 1]
      if (clearance) *clearance = (1.0 - kStep) * smallest_gap - min_distance;
      return std::nullopt;
    }
    t = t_next;
    for (std::size_t k = 0; k < 4; ++k) xt[k] = x[k] + t * d_in[k];
    gap_now = closest(kind, xt).distance - min_distance;
    smallest_gap = std::min(smallest_gap, gap_now);
    if (gap_now < stop_gap) {
      if (approach_rate(kind, xt, d_in) < 0.0) return t;
      stop_gap = std::min(stop_gap, (1.0 - kStep) * gap_now);  // close but separating: watch on
    }
  }
  return t;  // undecided: reported, to be safe
}

}  // namespace goo::ccd
