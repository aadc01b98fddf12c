#include "meshing/remesh_trigger.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <limits>

#include "core/parallel.h"
#include "core/svd3.h"

namespace goo {

double condition_number(const Eigen::Matrix3d& Ds) {
  const Eigen::Vector3d s = svd3(Ds).sigma;
  if (!(s[2] > 0.0)) return std::numeric_limits<double>::infinity();
  return s[0] / s[2];
}

RemeshCheck check_remesh(const Body& body, const Points& x,
                         const Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor>& bary,
                         const RemeshThresholds& thresholds) {
  RemeshCheck out;
  // Serial: a max and a first index are the same in any order, and this
  // costs one SVD per element, like a force evaluation.
  for (Index e = 0; e < body.num_elements(); ++e) {
    const Eigen::Vector3d x0 = x.row(body.tets(e, 0));
    Eigen::Matrix3d Ds;
    for (int k = 0; k < 3; ++k) Ds.col(k) = x.row(body.tets(e, k + 1)).transpose() - x0;
    if (!(Ds.determinant() > 0.0)) ++out.inverted;
    const double growth = condition_number(Ds) / body.rest_condition[e];
    if (growth > out.worst_growth) out.worst_growth = growth;
    if (growth > thresholds.condition_growth && out.element < 0) out.element = e;
  }
  for (Eigen::Index v = 0; v < bary.rows(); ++v) {
    if (bary.row(v).minCoeff() < thresholds.min_barycentric) {
      out.vertex = static_cast<Index>(v);
      break;
    }
  }
  out.due = out.element >= 0 || out.vertex >= 0;
  return out;
}

bool remesh_due(const Body& body, const Points& x, const Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor>& bary,
                const RemeshThresholds& thresholds) {
  // A yes/no answer is the same in any order, so the flag may be set by any thread.
  std::atomic<bool> due{false};
  tbb::parallel_for(tbb::blocked_range<Index>(0, body.num_elements(), kParallelGrain),
                    [&](const tbb::blocked_range<Index>& r) {
                      if (due.load(std::memory_order_relaxed)) return;
                      for (Index e = r.begin(); e != r.end(); ++e) {
                        const Eigen::Vector3d x0 = x.row(body.tets(e, 0));
                        Eigen::Matrix3d Ds;
                        for (int k = 0; k < 3; ++k) Ds.col(k) = x.row(body.tets(e, k + 1)).transpose() - x0;
                        const double det = Ds.determinant();
                        const double bound = thresholds.condition_growth * body.rest_condition[e];
                        // ‖Ds⁻¹‖_F = ‖cof(Ds)‖_F / |det Ds|; no division, so flat elements fall through.
                        Eigen::Matrix3d cof;
                        cof.col(0) = Ds.col(1).cross(Ds.col(2));
                        cof.col(1) = Ds.col(2).cross(Ds.col(0));
                        cof.col(2) = Ds.col(0).cross(Ds.col(1));
                        if (det > 0.0 && Ds.norm() * cof.norm() <= bound * det) continue;
                        if (condition_number(Ds) > bound) {
                          due.store(true, std::memory_order_relaxed);
                          return;
                        }
                      }
                    });
  if (due.load()) return true;
  // A surface vertex drifted too far outside its element (in parallel runs).
  return any_index(
      static_cast<Index>(bary.rows()), [&](Index v) { return bary.row(v).minCoeff() < thresholds.min_barycentric; },
      4096);
}

}  // namespace goo
