#include "core/contact/calm_stars.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/SVD>
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>

#include "core/contact/box_pairs.h"
#include "core/contact/ccd.h"
#include "core/parallel.h"
#include "core/radix_sort.h"

namespace goo {
namespace {

using Vec3 = Eigen::Vector3d;

// κ × ratio must stay below 1 all step for a group's pairs to go unmeasured
// (with room for the rounding of κ, a few ulps of its terms); a list groups
// only stars with κ × kRatio at most three quarters of the way there.
constexpr double kUnsafe = 1.0 - 1e-9;
constexpr double kGroupable = 0.75;
// kRatio less the bound's margin (pair_ratio).
constexpr double kRatioBound = CalmStars::kRatio * (1.0 - 1e-6);

double smallest_singular_value(const Eigen::Matrix3d& A) {
  return Eigen::JacobiSVD<Eigen::Matrix3d>(A).singularValues()(2);
}

Eigen::Matrix3d edge_matrix(const Tets& tets, const Points& x, Index e) {
  Eigen::Matrix3d D;
  const Index n0 = tets(e, 0);
  for (int k = 1; k < 4; ++k) D.col(k - 1) = (x.row(tets(e, k)) - x.row(n0)).transpose();
  return D;
}

/// The largest ratio D / d over the primitive pairs of triangles a and b
/// (rest corners pa, pb; vertex ids ia, ib) that share no vertex and do not
/// lie in one element: every pair the self-collision list can hold of them.
///
/// Only whether the ratio exceeds kRatio, and if it does its value, count:
/// a primitive pair whose D is at most kRatio × a lower bound of its d is
/// not measured (its ratio cannot exceed kRatio, so it changes neither).
/// The bound: a triangle lies in the ball about its corners' mean through
/// its farthest corner, an edge in the ball about its midpoint, so d ≥
/// |c_a − c_b| − r_a − r_b; with a relative margin of 10⁻⁶, far above the
/// rounding of D, d and the bound where the bound is at least D / kRatio
/// (the sides are then apart by a quarter of their extent and every
/// distance is well conditioned).
double pair_ratio(const std::array<Index, 3>& ia, const std::array<Index, 3>& ib, const std::array<Vec3, 3>& pa,
                  const std::array<Vec3, 3>& pb, const std::vector<Index>& parent) {
  struct Ball {
    Vec3 centre;
    double radius;
  };
  auto triangle_ball = [](const std::array<Vec3, 3>& p) {
    const Vec3 c = (p[0] + p[1] + p[2]) / 3.0;
    return Ball{c, std::sqrt(std::max({(p[0] - c).squaredNorm(), (p[1] - c).squaredNorm(), (p[2] - c).squaredNorm()}))};
  };
  auto edge_ball = [](const Vec3& p, const Vec3& q) { return Ball{0.5 * (p + q), 0.5 * (p - q).norm()}; };
  const std::array<Ball, 2> triangle{triangle_ball(pa), triangle_ball(pb)};
  std::array<std::array<Ball, 3>, 2> edge;
  for (std::size_t k = 0; k < 3; ++k) {
    edge[0][k] = edge_ball(pa[k], pa[(k + 1) % 3]);
    edge[1][k] = edge_ball(pb[k], pb[(k + 1) % 3]);
  }
  double ratio = 0.0;
  auto consider = [&](ccd::PairKind kind, const ccd::Points4& x, const std::array<Index, 4>& v, std::size_t first,
                      const Ball& a, const Ball& b) {
    const Index e = parent[at(v[0])];
    if (parent[at(v[1])] == e && parent[at(v[2])] == e && parent[at(v[3])] == e) return;
    double D2 = 0.0;
    for (std::size_t i = 0; i < first; ++i)
      for (std::size_t j = first; j < 4; ++j) D2 = std::max(D2, (x[i] - x[j]).squaredNorm());
    const double apart = (a.centre - b.centre).norm() - a.radius - b.radius;
    if (apart > 0.0 && D2 <= kRatioBound * apart * (kRatioBound * apart)) return;
    const double D = std::sqrt(D2);  // the largest of the distances, as √ is monotonic
    const double d = ccd::closest(kind, x).distance;
    ratio = std::max(ratio, d > 0.0 ? D / d : std::numeric_limits<double>::infinity());
  };
  auto shares = [](Index v, const std::array<Index, 3>& t) { return v == t[0] || v == t[1] || v == t[2]; };
  for (int side = 0; side < 2; ++side) {
    const auto& iv = side == 0 ? ia : ib;
    const auto& it = side == 0 ? ib : ia;
    const auto& pv = side == 0 ? pa : pb;
    const auto& pt = side == 0 ? pb : pa;
    for (std::size_t k = 0; k < 3; ++k)
      if (!shares(iv[k], it))
        consider(ccd::PairKind::vertex_triangle, {pv[k], pt[0], pt[1], pt[2]}, {iv[k], it[0], it[1], it[2]}, 1,
                 Ball{pv[k], 0.0}, triangle[side == 0 ? 1 : 0]);
  }
  for (std::size_t a = 0; a < 3; ++a)
    for (std::size_t b = 0; b < 3; ++b) {
      const std::size_t a1 = (a + 1) % 3, b1 = (b + 1) % 3;
      if (ia[a] == ib[b] || ia[a] == ib[b1] || ia[a1] == ib[b] || ia[a1] == ib[b1]) continue;
      consider(ccd::PairKind::edge_edge, {pa[a], pa[a1], pb[b], pb[b1]}, {ia[a], ia[a1], ib[b], ib[b1]}, 2, edge[0][a],
               edge[1][b]);
    }
  return ratio;
}

/// A lower bound of σ_min(A) without an SVD: σ_min² is the least
/// eigenvalue of B = AᵀA, at least min_i (B_ii − Σ_{j≠i} |B_ij|)
/// (Gershgorin). 0 (no bound) where that is below 10⁻⁶ of B's largest
/// diagonal entry: there its rounding (ε of B) would pass the 10⁻⁹ margin.
double smallest_singular_value_bound(const Eigen::Matrix3d& A) {
  const Eigen::Matrix3d B = A.transpose() * A;
  double least = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 3; ++i)
    least = std::min(least, B(i, i) - std::abs(B(i, (i + 1) % 3)) - std::abs(B(i, (i + 2) % 3)));
  return least > 1e-6 * B.diagonal().maxCoeff() ? std::sqrt(least) : 0.0;
}

/// The relative margin by which a κ from the bounds is taken above the one
/// from the SVD: far above the rounding of either.
constexpr double kBoundMargin = 1e-9;

/// star_spread of `count` tets whose gradients are F0(k) and F1(k), read
/// where they are (a star's from the per-element arrays: no copies).
///
/// With a `multiplier` m and `threshold` τ (the test the caller puts κ to,
/// κ m < τ): first κ from σ_min's Gershgorin bounds, which is at least the
/// SVD's (s falls with s0 and s1); if that passes the test, it is returned,
/// and the SVD's, smaller, passes it too, so every decision the caller
/// takes on it is the same. Otherwise (and without a test) κ from the SVD.
template <class Start, class End>
double spread_of(std::size_t count, Start&& F0, End&& F1, double multiplier = 0.0, double threshold = 0.0) {
  if (count == 0) return std::numeric_limits<double>::infinity();
  Eigen::Matrix3d A0 = Eigen::Matrix3d::Zero(), A1 = Eigen::Matrix3d::Zero();
  for (std::size_t k = 0; k < count; ++k) {
    A0 += F0(k);
    A1 += F1(k);
  }
  A0 /= double(count);
  A1 /= double(count);
  double L = 0.0;
  for (std::size_t k = 0; k < count; ++k) L = std::max({L, (F0(k) - A0).norm(), (F1(k) - A1).norm()});
  if (multiplier > 0.0) {
    const double b0 = smallest_singular_value_bound(A0), b1 = smallest_singular_value_bound(A1);
    const double s = std::min({b0, b1, 0.5 * (b0 + b1 - (A1 - A0).norm())});
    if (s > 0.0) {
      const double kappa = (1.0 + kBoundMargin) * (L / s);
      if (kappa * multiplier < threshold) return kappa;
    }
  }
  const double s0 = smallest_singular_value(A0), s1 = smallest_singular_value(A1), delta = (A1 - A0).norm();
  const double s = std::min({s0, s1, 0.5 * (s0 + s1 - delta)});
  return s > 0.0 ? L / s : std::numeric_limits<double>::infinity();
}

}  // namespace

double star_spread(const std::vector<Eigen::Matrix3d>& F0, const std::vector<Eigen::Matrix3d>& F1, double multiplier,
                   double threshold) {
  return spread_of(
      F0.size(), [&](std::size_t k) -> const Eigen::Matrix3d& { return F0[k]; },
      [&](std::size_t k) -> const Eigen::Matrix3d& { return F1[k]; }, multiplier, threshold);
}

bool CalmStars::update_mesh(const Body& body) {
  if (same_bits(tets_, body.tets) && same_bits(rest_, body.rest_positions)) return false;
  tets_ = body.tets;
  rest_ = body.rest_positions;
  const Index ne = static_cast<Index>(tets_.rows()), nn = static_cast<Index>(rest_.rows());
  eligible_.assign(at(nn), 0);
  rest_inverse_.assign(at(ne), Eigen::Matrix3d::Zero());
  if (nn != body.num_nodes() || ne == 0) return true;
  incidence_ = NodeIncidence::build(tets_, nn);
  std::vector<std::uint8_t> positive(at(ne), 0);
  for (Index e = 0; e < ne; ++e) {
    const Eigen::Matrix3d D = edge_matrix(tets_, rest_, e);
    if (D.determinant() > 0.0) {
      positive[at(e)] = 1;
      rest_inverse_[at(e)] = D.inverse();
    }
  }
  tbb::parallel_for(tbb::blocked_range<Index>(0, nn, 256), [&](const tbb::blocked_range<Index>& r) {
    for (Index n = r.begin(); n != r.end(); ++n) {
      const auto begin = incidence_.offsets[at(n)], end = incidence_.offsets[at(n) + 1];
      if (begin == end) continue;
      bool ok = true;
      // Closed: every face through n is shared by two tets of the star,
      // i.e. every link edge appears twice.
      std::vector<std::array<Index, 2>> link_edges;
      std::vector<Index> link;
      for (Index c = begin; c < end && ok; ++c) {
        const Index e = incidence_.corners[at(c)] / 4, k = incidence_.corners[at(c)] % 4;
        ok = positive[at(e)] != 0;
        std::array<Index, 3> o{};
        for (int i = 1; i < 4; ++i) o[at(i - 1)] = tets_(e, (k + i) % 4);
        for (int i = 0; i < 3; ++i) {
          link_edges.push_back({std::min(o[at(i)], o[at((i + 1) % 3)]), std::max(o[at(i)], o[at((i + 1) % 3)])});
          link.push_back(o[at(i)]);
        }
      }
      if (!ok) continue;
      std::sort(link_edges.begin(), link_edges.end());
      for (std::size_t i = 0; i < link_edges.size() && ok; i += 2)
        ok = i + 1 < link_edges.size() && link_edges[i] == link_edges[i + 1] &&
             (i + 2 >= link_edges.size() || link_edges[i + 2] != link_edges[i]);
      if (!ok) continue;
      std::sort(link.begin(), link.end());
      link.erase(std::unique(link.begin(), link.end()), link.end());
      // Convex: every link vertex on n's side of (or on) every outer face's plane.
      const Vec3 xn = rest_.row(n).transpose();
      for (Index c = begin; c < end && ok; ++c) {
        const Index e = incidence_.corners[at(c)] / 4, k = incidence_.corners[at(c)] % 4;
        const Vec3 a = rest_.row(tets_(e, (k + 1) % 4)).transpose(), b = rest_.row(tets_(e, (k + 2) % 4)).transpose(),
                   cc = rest_.row(tets_(e, (k + 3) % 4)).transpose();
        Vec3 normal = (b - a).cross(cc - a);
        if (normal.dot(xn - a) > 0.0) normal = -normal;
        const double scale = std::max({(b - a).norm(), (cc - a).norm(), (xn - a).norm()});
        const double tolerance = 1e-9 * normal.norm() * scale;
        for (const Index w : link)
          if (normal.dot(rest_.row(w).transpose() - a) > tolerance) ok = false;
      }
      eligible_[at(n)] = ok ? 1 : 0;
    }
  });
  return true;
}

void CalmStars::update_surface(const Body& body, const std::vector<Index>& element_of) {
  const Triangles& tris = body.surface_triangles;
  if (triangles_.rows() == tris.rows() && triangles_ == tris && parents_ == body.embedding.parent &&
      bary_.rows() == body.embedding.bary.rows() && bary_ == body.embedding.bary)
    return;
  triangles_ = tris;
  parents_ = body.embedding.parent;
  bary_ = body.embedding.bary;
  near_.clear();
  near_ratio_.clear();
  near_order_.clear();
  candidates_.clear();
  if (rest_.rows() != body.num_nodes()) return;
  surface_rest_ = body.embedding.surface_positions(body.tets, body.rest_positions);
  const Index nt = static_cast<Index>(tris.rows());
  // Only triangles that can join a group (a whole star holds their
  // corners) have near pairs that count, and only with a triangle that can
  // join the same one: the others' boxes stay empty.
  std::vector<Box3> boxes(at(nt));
  const auto& parent = body.embedding.parent;
  candidates_.assign(at(nt), {-1, -1, -1, -1});
  star_has_surface_.assign(eligible_.size(), 0);
  for (Index t = 0; t < nt; ++t) {
    bool any = false;
    for (int k = 0; k < 4; ++k) {
      const Index n = body.tets(parent[at(tris(t, 0))], k);
      bool held = eligible_.size() == at(body.num_nodes()) && eligible_[at(n)];
      for (int c = 1; c < 3 && held; ++c) {
        const Index e = parent[at(tris(t, c))];
        held = body.tets(e, 0) == n || body.tets(e, 1) == n || body.tets(e, 2) == n || body.tets(e, 3) == n;
      }
      if (held) {
        candidates_[at(t)][at(k)] = n;
        star_has_surface_[at(n)] = 1;
        any = true;
      }
    }
    if (!any) continue;
    Box3 b;
    double diameter = 0.0;
    for (int k = 0; k < 3; ++k) {
      b.extend(Vec3(surface_rest_.row(tris(t, k)).transpose()));
      diameter = std::max(diameter, (surface_rest_.row(tris(t, k)) - surface_rest_.row(tris(t, (k + 1) % 3))).norm());
    }
    const double grow = diameter / (kRatio - 1.0);
    b.min().array() -= grow;
    b.max().array() += grow;
    boxes[at(t)] = b;
  }
  const auto pairs = overlapping_pairs(boxes, &element_of);  // two in one element hold one-element pairs only
  // Each triangle's ball (about its corners' mean, through its farthest
  // corner), as pair_ratio takes it: a pair whose two balls keep every
  // primitive pair below the ratio needs no primitive measured. Points of
  // the two balls lie at most |c_a − c_b| + r_a + r_b apart and at least
  // |c_a − c_b| − r_a − r_b, which bounds every D and d alike; with the
  // same margin of 10⁻⁶ as pair_ratio's bound.
  std::vector<std::array<double, 4>> ball(at(nt));
  for_each_index(nt, [&](Index t) {
    const Vec3 c =
        (surface_rest_.row(tris(t, 0)) + surface_rest_.row(tris(t, 1)) + surface_rest_.row(tris(t, 2))).transpose() /
        3.0;
    double r2 = 0.0;
    for (int k = 0; k < 3; ++k) r2 = std::max(r2, (surface_rest_.row(tris(t, k)).transpose() - c).squaredNorm());
    ball[at(t)] = {c.x(), c.y(), c.z(), std::sqrt(r2)};
  });
  std::vector<double> ratio(pairs.size(), 0.0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, pairs.size(), 1024), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      bool common = false;
      for (const Index n : candidates_[at(pairs[i][0])])
        for (const Index m : candidates_[at(pairs[i][1])]) common = common || (n >= 0 && n == m);
      if (!common) continue;  // never in one group
      const auto &a = ball[at(pairs[i][0])], &b = ball[at(pairs[i][1])];
      const double centres =
          std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
      const double apart = centres - a[3] - b[3];
      if (apart > 0.0 && centres + a[3] + b[3] <= kRatioBound * apart) continue;  // every ratio below kRatio
      std::array<Index, 3> ia{}, ib{};
      std::array<Vec3, 3> pa, pb;
      for (int k = 0; k < 3; ++k) {
        ia[at(k)] = tris(pairs[i][0], k);
        ib[at(k)] = tris(pairs[i][1], k);
        pa[at(k)] = surface_rest_.row(ia[at(k)]).transpose();
        pb[at(k)] = surface_rest_.row(ib[at(k)]).transpose();
      }
      ratio[i] = pair_ratio(ia, ib, pa, pb, parents_);
    }
  });
  for (std::size_t i = 0; i < pairs.size(); ++i)
    if (!(ratio[i] <= kRatio)) {
      near_.push_back(pairs[i]);
      near_ratio_.push_back(ratio[i]);
    }
  // Largest ratio first, then in list order: each build's groups take
  // their near pairs in this order (a stable sort by ratio, done once).
  near_order_.resize(near_.size());
  // A radix sort by the ratio's bits, complemented (a positive double's
  // bits, read as an integer, grow with it; the ratios are above kRatio or
  // +∞, never NaN: std::max keeps the ratio so far against a NaN), stable:
  // the order of the comparison (ratio descending, then index) at a fifth
  // of std::sort's cost (the armadillo's 200k near pairs: 27 → 5–6 ms).
  std::iota(near_order_.begin(), near_order_.end(), Index{0});
  radix_sort(near_order_, [&](Index i) { return ~std::bit_cast<std::uint64_t>(near_ratio_[at(i)]); });
}

void CalmStars::gradients(const Body& body, const Points& x0, const Points& d,
                          const std::vector<std::uint8_t>* elements) {
  const Index ne = body.num_elements();
  F0_.resize(at(ne));
  F1_.resize(at(ne));
  const Points x1 = x0 + d;
  tbb::parallel_for(tbb::blocked_range<Index>(0, ne, kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
    for (Index e = r.begin(); e != r.end(); ++e) {
      if (elements && !(*elements)[at(e)]) continue;
      F0_[at(e)] = edge_matrix(body.tets, x0, e) * rest_inverse_[at(e)];
      F1_[at(e)] = edge_matrix(body.tets, x1, e) * rest_inverse_[at(e)];
    }
  });
}

void CalmStars::gradients(const Body& body, const Points& x0, const Points& d, const std::vector<Index>& elements) {
  // As the pass over every element computes them: x1 = x0 + d row by row.
  for_each_index(
      static_cast<Index>(elements.size()),
      [&](Index i) {
        const Index e = elements[at(i)];
        const Index n0 = body.tets(e, 0);
        const Eigen::RowVector3d p0 = x0.row(n0) + d.row(n0);
        Eigen::Matrix3d D1;
        for (int k = 1; k < 4; ++k) {
          const Index n = body.tets(e, k);
          D1.col(k - 1) = (Eigen::RowVector3d(x0.row(n) + d.row(n)) - p0).transpose();
        }
        F0_[at(e)] = edge_matrix(body.tets, x0, e) * rest_inverse_[at(e)];
        F1_[at(e)] = D1 * rest_inverse_[at(e)];
      },
      64);
}

double CalmStars::spread(const Body& body, Index n, double multiplier, double threshold) const {
  (void)body;
  const Index first = incidence_.offsets[at(n)];
  auto element = [&](std::size_t k) { return at(incidence_.corners[at(first) + k] / 4); };
  return spread_of(
      at(incidence_.offsets[at(n) + 1] - first),
      [&](std::size_t k) -> const Eigen::Matrix3d& { return F0_[element(k)]; },
      [&](std::size_t k) -> const Eigen::Matrix3d& { return F1_[element(k)]; }, multiplier, threshold);
}

std::vector<Index> CalmStars::assign_groups(const Body& body, const Points& x0, const Points& d) {
  const Index nt = static_cast<Index>(body.surface_triangles.rows());
  const Index nn = body.num_nodes();
  group_.assign(at(nt), -1);
  kappa_.assign(at(nn), std::numeric_limits<double>::infinity());
  full_.assign(at(nn), 0);
  near_listed_.assign(at(nn), 0);
  offsets_.assign(at(nn) + 1, 0);
  near_offsets_.assign(at(nn) + 1, 0);
  near_members_.clear();
  members_.clear();
  grouped_.clear();
  if (eligible_.size() != at(nn) || candidates_.size() != at(nt) || star_has_surface_.size() != at(nn) ||
      surface_rest_.rows() != body.embedding.num_vertices())
    return group_;
  gradients(body, x0, d, nullptr);
  tbb::parallel_for(tbb::blocked_range<Index>(0, nn, 64), [&](const tbb::blocked_range<Index>& r) {
    for (Index n = r.begin(); n != r.end(); ++n)
      if (eligible_[at(n)] && star_has_surface_[at(n)]) kappa_[at(n)] = spread(body, n, kRatio, kGroupable);
  });
  const Triangles& tris = body.surface_triangles;
  for_each_index(nt, [&](Index t) {  // each triangle its own group: in parallel
    bool inside = true;
    for (int k = 0; k < 3 && inside; ++k) inside = (body.embedding.bary.row(tris(t, k)).array() >= 0.0).all();
    if (!inside) return;
    const Vec3 centroid =
        (surface_rest_.row(tris(t, 0)) + surface_rest_.row(tris(t, 1)) + surface_rest_.row(tris(t, 2))).transpose() / 3.0;
    double best = std::numeric_limits<double>::infinity();
    for (const Index n : candidates_[at(t)]) {
      if (n < 0 || !(kappa_[at(n)] * kRatio < kGroupable)) continue;
      const double dist = (body.rest_positions.row(n).transpose() - centroid).squaredNorm();
      if (dist < best || (dist == best && n < group_[at(t)])) {
        best = dist;
        group_[at(t)] = n;
      }
    }
  });
  // Each group's near pairs, largest ratio first (then by pair).
  for (std::size_t i = 0; i < near_.size(); ++i) {
    const Index g = group_[at(near_[i][0])];
    if (g >= 0 && g == group_[at(near_[i][1])]) ++near_offsets_[at(g) + 1];
  }
  for (Index n = 0; n < nn; ++n) near_offsets_[at(n) + 1] += near_offsets_[at(n)];
  near_members_.resize(at(near_offsets_[at(nn)]));
  {
    std::vector<Index> next(near_offsets_.begin(), near_offsets_.end() - 1);
    for (const Index i : near_order_) {  // by ratio, largest first: each group's come out in that order
      const Index g = group_[at(near_[at(i)][0])];
      if (g >= 0 && g == group_[at(near_[at(i)][1])]) near_members_[at(next[at(g)]++)] = i;
    }
  }
  for (Index t = 0; t < nt; ++t)
    if (group_[at(t)] >= 0) ++offsets_[at(group_[at(t)]) + 1];
  for (Index n = 0; n < nn; ++n) {
    if (offsets_[at(n) + 1] > 0) grouped_.push_back(n);
    offsets_[at(n) + 1] += offsets_[at(n)];
  }
  members_.resize(at(offsets_[at(nn)]));
  std::vector<Index> next(offsets_.begin(), offsets_.end() - 1);
  for (Index t = 0; t < nt; ++t)
    if (group_[at(t)] >= 0) members_[at(next[at(group_[at(t)])]++)] = t;
  return group_;
}

bool CalmStars::returned(Index a, Index b) const {
  const Index n = group_[at(a)];
  if (n < 0 || group_[at(b)] != n) return false;
  if (full_[at(n)]) return true;
  const std::array<Index, 2> pair{std::min(a, b), std::max(a, b)};
  for (Index k = near_offsets_[at(n)]; k < near_offsets_[at(n)] + near_listed_[at(n)]; ++k)
    if (near_[at(near_members_[at(k)])] == pair) return true;
  return false;
}

std::vector<std::array<Index, 2>> CalmStars::newly_unsafe(const Body& body, const Points& x0, const Points& d,
                                                          const std::vector<std::uint8_t>* moved,
                                                          const std::vector<Box3>& boxes,
                                                          const std::vector<Index>* moved_elements) {
  if (grouped_.empty()) return {};
  const Index ne = body.num_elements();
  // Star n's κ this step, tested below as κ × kRatio and κ × the next near
  // pair's ratio (the largest not yet returned) against kUnsafe: with κ
  // under both, nothing is returned.
  auto measure = [&](Index n) {
    const Index next = near_offsets_[at(n)] + near_listed_[at(n)];
    const double largest =
        next < near_offsets_[at(n) + 1] ? std::max(kRatio, near_ratio_[at(near_members_[at(next)])]) : kRatio;
    kappa_[at(n)] = spread(body, n, largest, kUnsafe);
  };
  std::vector<std::array<Index, 2>> out;
  auto take = [&](Index n) {  // the pairs star n's κ makes unsafe, in one order
    const double kappa = kappa_[at(n)];
    const Index near_begin = near_offsets_[at(n)], near_end = near_offsets_[at(n) + 1];
    if (!(kappa * kRatio < kUnsafe)) {  // every pair of the group
      full_[at(n)] = 1;
      std::vector<std::array<Index, 2>> listed;
      for (Index k = near_begin; k < near_begin + near_listed_[at(n)]; ++k)
        listed.push_back(near_[at(near_members_[at(k)])]);
      std::sort(listed.begin(), listed.end());
      const std::vector<Index> own = members(n);
      std::vector<Box3> own_boxes;
      own_boxes.reserve(own.size());
      for (const Index t : own) own_boxes.push_back(boxes[at(t)]);
      for (const auto& p : overlapping_pairs(own_boxes, nullptr)) {
        const std::array<Index, 2> pair{own[at(p[0])], own[at(p[1])]};
        if (!std::binary_search(listed.begin(), listed.end(), pair)) out.push_back(pair);
      }
      return;
    }
    // Below that, only near pairs can touch: those whose κ × ratio reaches 1.
    Index& k = near_listed_[at(n)];
    while (near_begin + k < near_end && !(kappa * near_ratio_[at(near_members_[at(near_begin + k)])] < kUnsafe)) {
      out.push_back(near_[at(near_members_[at(near_begin + k)])]);
      ++k;
    }
  };
  if (moved && moved_elements) {
    // The stars holding a moved element are those of its nodes: the grouped
    // ones not yet full, ascending (grouped_'s order).
    gradients(body, x0, d, *moved_elements);
    const Index nn = body.num_nodes();
    if (star_stamp_.size() != at(nn) || star_call_ == std::numeric_limits<Index>::max()) {
      star_stamp_.assign(at(nn), 0);
      star_call_ = 0;
    }
    ++star_call_;
    std::vector<Index> stars;
    for (const Index e : *moved_elements)
      for (int k = 0; k < 4; ++k) {
        const Index n = body.tets(e, k);
        if (star_stamp_[at(n)] == star_call_) continue;
        star_stamp_[at(n)] = star_call_;
        if (offsets_[at(n) + 1] > offsets_[at(n)] && !full_[at(n)]) stars.push_back(n);
      }
    std::sort(stars.begin(), stars.end());
    for_each_index(
        static_cast<Index>(stars.size()), [&](Index i) { measure(stars[at(i)]); }, 16);
    for (const Index n : stars) take(n);
    return out;
  }
  std::vector<std::uint8_t> elements(at(ne), moved ? 0 : 1);
  if (moved)
    for_each_index(ne, [&](Index e) {
      for (int k = 0; k < 4; ++k) elements[at(e)] |= (*moved)[at(body.tets(e, k))];
    });
  gradients(body, x0, d, &elements);
  std::vector<std::uint8_t> touched(grouped_.size(), 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, grouped_.size(), 16),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i) {
                        const Index n = grouped_[i];
                        if (full_[at(n)]) continue;
                        bool star_moved = !moved;
                        for (Index c = incidence_.offsets[at(n)]; c < incidence_.offsets[at(n) + 1] && !star_moved; ++c)
                          star_moved = elements[at(incidence_.corners[at(c)] / 4)] != 0;
                        if (!star_moved) continue;
                        measure(n);
                        touched[i] = 1;
                      }
                    });
  for (std::size_t i = 0; i < grouped_.size(); ++i)
    if (touched[i]) take(grouped_[i]);
  return out;
}

}  // namespace goo
