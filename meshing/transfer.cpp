#include "meshing/transfer.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>

#include "core/error.h"
#include "core/parallel.h"
#include "core/svd3.h"
#include "meshing/convex_clip.h"
#include "meshing/lattice_slicing.h"

namespace goo {
namespace {

/// An old element in its deformed shape.
struct OldElement {
  std::array<Eigen::Vector3d, 4> x;
  Eigen::Matrix3d Ds_inv;
  Eigen::Vector3d lo, hi;
  bool usable = false;  // positively oriented, not flat
};

std::vector<OldElement> old_elements(const Tets& tets, const Points& x) {
  std::vector<OldElement> out(static_cast<std::size_t>(tets.rows()));
  tbb::parallel_for(tbb::blocked_range<Index>(0, static_cast<Index>(tets.rows()), kParallelGrain),
                    [&](const tbb::blocked_range<Index>& r) {
                      for (Index e = r.begin(); e != r.end(); ++e) {
                        OldElement& o = out[at(e)];
                        for (int k = 0; k < 4; ++k) o.x[static_cast<std::size_t>(k)] = x.row(tets(e, k)).transpose();
                        Eigen::Matrix3d Ds;
                        for (int k = 0; k < 3; ++k) Ds.col(k) = o.x[static_cast<std::size_t>(k + 1)] - o.x[0];
                        o.lo = o.x[0].cwiseMin(o.x[1]).cwiseMin(o.x[2]).cwiseMin(o.x[3]);
                        o.hi = o.x[0].cwiseMax(o.x[1]).cwiseMax(o.x[2]).cwiseMax(o.x[3]);
                        // Flat when the volume is below 1e-12 of the bounding box's cube.
                        const double scale = (o.hi - o.lo).maxCoeff();
                        const double det = Ds.determinant();
                        o.usable = std::isfinite(det) && det > 1e-12 * scale * scale * scale;
                        if (o.usable) o.Ds_inv = Ds.inverse();
                      }
                    });
  return out;
}

Eigen::Vector4d barycentric(const OldElement& o, const Eigen::Vector3d& p) {
  const Eigen::Vector3d b = o.Ds_inv * (p - o.x[0]);
  return {1.0 - b.sum(), b.x(), b.y(), b.z()};
}

double distance_to(const OldElement& o, const Eigen::Vector3d& p) {
  if (barycentric(o, p).minCoeff() >= 0.0) return 0.0;
  double d = std::numeric_limits<double>::infinity();
  for (const auto& f : kTetFaces)
    d = std::min(d, point_triangle_distance(p, o.x[static_cast<std::size_t>(f[0])], o.x[static_cast<std::size_t>(f[1])],
                                            o.x[static_cast<std::size_t>(f[2])]));
  return d;
}

/// The distance from p to o's bounding box: at most p's distance to o.
double box_distance(const OldElement& o, const Eigen::Vector3d& p) {
  return ((o.lo - p).cwiseMax(0.0) + (p - o.hi).cwiseMax(0.0)).norm();
}

/// Runs f(old element, output list) over old elements in fixed chunks, in
/// parallel; returns the lists in chunk order.
template <class T, class F>
std::vector<std::vector<T>> per_old_chunk(std::size_t count, F&& f) {
  constexpr std::size_t kChunk = 256;
  std::vector<std::vector<T>> chunks((count + kChunk - 1) / kChunk);
  tbb::parallel_for(std::size_t{0}, chunks.size(), [&](std::size_t chunk) {
    for (std::size_t k = chunk * kChunk; k < std::min(count, (chunk + 1) * kChunk); ++k)
      f(static_cast<Index>(k), chunks[chunk]);
  });
  return chunks;
}

struct Candidate {
  Index node;
  Index element;
  double score;  // larger wins: min barycentric coordinate, or minus a distance
};

/// Keeps, per node, the candidate of highest score, the lower element on a
/// tie: a total order, so the result does not depend on the visiting order.
void keep_best(const std::vector<std::vector<Candidate>>& chunks, std::vector<Index>& element,
               std::vector<double>& score) {
  for (const auto& chunk : chunks)
    for (const Candidate& c : chunk) {
      const std::size_t n = at(c.node);
      if (element[n] < 0 || c.score > score[n] || (c.score == score[n] && c.element < element[n])) {
        element[n] = c.element;
        score[n] = c.score;
      }
    }
}

}  // namespace

NodeSources locate_in_old_mesh(const Tets& old_tets, const Points& old_x, const LatticeMesh& new_mesh) {
  const std::vector<OldElement> old = old_elements(old_tets, old_x);
  if (std::none_of(old.begin(), old.end(), [](const OldElement& o) { return o.usable; }))
    throw Error("re-mesh: every element of the old mesh is inverted or flat");
  const BccLattice& lattice = new_mesh.lattice;
  const Index nn = new_mesh.mesh.num_nodes();
  std::vector<Index> element(at(nn), -1);
  std::vector<double> score(at(nn), -std::numeric_limits<double>::infinity());
  // Interpolation: the new nodes inside each old element's box.
  const double tolerance = 1e-12;
  keep_best(per_old_chunk<Candidate>(old.size(),
                                     [&](Index k, std::vector<Candidate>& found) {
                                       const OldElement& o = old[at(k)];
                                       if (!o.usable) return;
                                       lattice.for_each_node_in(o.lo, o.hi, [&](BccLattice::Key key) {
                                         const Index n = new_mesh.node(key);
                                         if (n < 0) return;
                                         const double b = barycentric(o, lattice.position(key)).minCoeff();
                                         if (b >= -tolerance) found.push_back({n, k, b});
                                       });
                                     }),
            element, score);
  // Extrapolation: the nearest old element, searched in growing boxes.
  NodeSources out;
  std::vector<std::uint8_t> missing(at(nn), 0);
  for (Index n = 0; n < nn; ++n) missing[at(n)] = element[at(n)] < 0;
  out.extrapolated = static_cast<Index>(std::count(missing.begin(), missing.end(), 1));
  double radius = lattice.spacing();
  Eigen::AlignedBox3d all;
  for (const auto& o : old) all.extend(o.lo).extend(o.hi);
  const double reach = 2.0 * (all.diagonal().norm() + (lattice.cells().cast<double>() * lattice.spacing()).norm());
  Index left = out.extrapolated;
  // Each round, first a bound on the distance of each node still missing:
  // its distance to the nearest corner of a usable old element within the
  // round's radius along each axis (a minimum, so the same for any order).
  // An element farther from the node than that, by its bounding box and a
  // margin far above the distances' round-off, can neither be the nearest
  // nor tie with it, and is not measured: the nearest element found is the
  // same as measuring every one gives (the least distance, the lower
  // element on a tie).
  std::vector<std::uint8_t> corner(static_cast<std::size_t>(old_x.rows()), 0);
  for (std::size_t k = 0; k < old.size(); ++k)
    if (old[k].usable)
      for (int i = 0; i < 4; ++i) corner[at(old_tets(static_cast<Index>(k), i))] = 1;
  std::vector<std::atomic<std::uint64_t>> bound(at(nn));
  while (left > 0) {
    if (radius > reach) throw Error("re-mesh: a new node is farther from the old mesh than the meshes are large");
    const Eigen::Vector3d grow = Eigen::Vector3d::Constant(radius);
    for (Index n = 0; n < nn; ++n) {
      missing[at(n)] = element[at(n)] < 0;  // found in an earlier round: the nearest already
      bound[at(n)].store(std::bit_cast<std::uint64_t>(std::numeric_limits<double>::infinity()),
                         std::memory_order_relaxed);
    }
    tbb::parallel_for(tbb::blocked_range<Index>(0, static_cast<Index>(old_x.rows()), kParallelGrain),
                      [&](const tbb::blocked_range<Index>& r) {
                        for (Index v = r.begin(); v != r.end(); ++v) {
                          if (!corner[at(v)]) continue;
                          const Eigen::Vector3d x = old_x.row(v).transpose();
                          lattice.for_each_node_in(x - grow, x + grow, [&](BccLattice::Key key) {
                            const Index n = new_mesh.node(key);
                            if (n < 0 || !missing[at(n)]) return;
                            const std::uint64_t bits = std::bit_cast<std::uint64_t>((x - lattice.position(key)).norm());
                            std::atomic<std::uint64_t>& slot = bound[at(n)];
                            std::uint64_t seen = slot.load(std::memory_order_relaxed);
                            while (bits < seen && !slot.compare_exchange_weak(seen, bits)) {
                            }
                          });
                        }
                      });
    keep_best(per_old_chunk<Candidate>(old.size(),
                                       [&](Index k, std::vector<Candidate>& found) {
                                         const OldElement& o = old[at(k)];
                                         if (!o.usable) return;
                                         lattice.for_each_node_in(o.lo - grow, o.hi + grow, [&](BccLattice::Key key) {
                                           const Index n = new_mesh.node(key);
                                           if (n < 0 || !missing[at(n)]) return;
                                           const Eigen::Vector3d p = lattice.position(key);
                                           const double most = std::bit_cast<double>(bound[at(n)].load());
                                           const double margin = 1e-9 * (lattice.spacing() + p.cwiseAbs().maxCoeff());
                                           if (box_distance(o, p) > most + margin) return;
                                           const double d = distance_to(o, p);
                                           if (d <= radius) found.push_back({n, k, -d});
                                         });
                                       }),
              element, score);
    left = 0;
    for (Index n = 0; n < nn; ++n)
      if (missing[at(n)] && element[at(n)] < 0) ++left;
    radius *= 2.0;
  }
  out.element = std::move(element);
  out.bary.resize(nn, 4);
  for (Index n = 0; n < nn; ++n)
    out.bary.row(n) = barycentric(old[at(out.element[at(n)])], new_mesh.mesh.positions.row(n).transpose()).transpose();
  return out;
}

Points interpolate(const NodeSources& sources, const Tets& old_tets, const Points& values) {
  const auto nn = static_cast<Index>(sources.element.size());
  Points out(nn, values.cols());
  for (Index n = 0; n < nn; ++n) {
    Eigen::RowVector3d v = Eigen::RowVector3d::Zero();
    for (int k = 0; k < 4; ++k) v += sources.bary(n, k) * values.row(old_tets(sources.element[at(n)], k));
    out.row(n) = v;
  }
  return out;
}

ElementOverlaps element_overlaps(const Tets& old_tets, const Points& old_x, const LatticeMesh& new_mesh) {
  const std::vector<OldElement> old = old_elements(old_tets, old_x);
  const BccLattice& lattice = new_mesh.lattice;
  const TetMesh& mesh = new_mesh.mesh;
  struct Overlap {
    Index element;
    Index old;
    double volume;
  };
  // Each old element sliced along the lattice's planes (lattice_slicing.h):
  // its part in each lattice tetrahedron, no candidate pairs to reject.
  const auto chunks = per_old_chunk<Overlap>(old.size(), [&](Index k, std::vector<Overlap>& found) {
    const OldElement& o = old[at(k)];
    if (!o.usable) return;
    thread_local LatticeSlicer slicer;  // scratch only: the parts do not depend on the thread
    thread_local std::vector<std::pair<BccLattice::Key, double>> parts;
    slicer.overlaps(lattice, o.x, 1e-12, parts);
    for (const auto& [key, volume] : parts)
      if (const Index e = new_mesh.element(key); e >= 0) found.push_back({e, k, volume});
  });
  ElementOverlaps out;
  out.offsets.assign(static_cast<std::size_t>(mesh.num_elements()) + 1, 0);
  for (const auto& chunk : chunks)
    for (const Overlap& o : chunk) ++out.offsets[at(o.element) + 1];
  for (std::size_t e = 0; e + 1 < out.offsets.size(); ++e) out.offsets[e + 1] += out.offsets[e];
  out.old_element.resize(at(out.offsets.back()));
  out.volume.resize(at(out.offsets.back()));
  std::vector<Index> fill(out.offsets.begin(), out.offsets.end() - 1);
  for (const auto& chunk : chunks)
    for (const Overlap& o : chunk) {
      const std::size_t slot = at(fill[at(o.element)]++);
      out.old_element[slot] = o.old;
      out.volume[slot] = o.volume;
    }
  return out;
}

ElasticState transfer_elastic_state(const ElementOverlaps& overlaps, const NodeSources& sources,
                                    const std::vector<Eigen::Matrix3d>& old_Fe, const Eigen::VectorXd& old_alpha,
                                    const LatticeMesh& new_mesh, double min_stretch) {
  // World-frame left stretches of the old elements, Fe = U Σ Vᵀ → U Σ Uᵀ,
  // averaged in the log (log-Euclidean mean): log S = U ln Σ Uᵀ. A plain
  // mean of stretches inflates the determinant (the mean of diag(2, ½) and
  // diag(½, 2) has det 25/16), so material that re-meshes often under large
  // shear would lose volume at every re-mesh; the log mean keeps det S the
  // volume-weighted geometric mean of the old determinants. Singular values
  // below min_stretch (inverted or flattened elements) are raised to it first.
  std::vector<Eigen::Matrix3d> stretch(old_Fe.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, old_Fe.size(), kParallelGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for_each_svd3(
                          r.begin(), r.end(), [&](std::size_t k) { return old_Fe[k]; },
                          [&](std::size_t k, const Svd3& svd) {
                            const Eigen::Vector3d log_sigma = svd.sigma.cwiseMax(min_stretch).array().log().matrix();
                            const Eigen::Matrix3d L = svd.U * log_sigma.asDiagonal() * svd.U.transpose();
                            stretch[k] = 0.5 * (L + L.transpose());
                          });
                    });
  const Index ne = new_mesh.mesh.num_elements();
  ElasticState out;
  out.Fe.resize(at(ne));
  out.alpha.resize(ne);
  tbb::parallel_for(tbb::blocked_range<Index>(0, ne, kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
    for (Index e = r.begin(); e != r.end(); ++e) {
      Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
      double alpha = 0.0, weight = 0.0;
      for (Index c = overlaps.offsets[at(e)]; c < overlaps.offsets[at(e) + 1]; ++c) {
        const double w = overlaps.volume[at(c)];
        const Index k = overlaps.old_element[at(c)];
        S += w * stretch[at(k)];
        alpha += w * old_alpha[k];
        weight += w;
      }
      if (!(weight > 0.0)) {
        S.setZero();
        alpha = 0.0;
        for (int i = 0; i < 4; ++i) {
          const Index k = sources.element[at(new_mesh.mesh.tets(e, i))];
          S += 0.25 * stretch[at(k)];
          alpha += 0.25 * old_alpha[k];
        }
        weight = 1.0;
      }
      S /= weight;
      alpha /= weight;
      // S = exp(mean log S): symmetric, eigenvalues ≥ min_stretch (the mean of logs ≥ ln min_stretch).
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(S);
      const Eigen::Vector3d lambda = eig.eigenvalues().array().exp().matrix().cwiseMax(min_stretch);
      out.Fe[at(e)] = eig.eigenvectors() * lambda.asDiagonal() * eig.eigenvectors().transpose();
      out.alpha[e] = alpha;
    }
  });
  return out;
}

}  // namespace goo
