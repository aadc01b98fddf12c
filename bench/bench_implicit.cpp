// The implicit path: Hessian assembly, CHOLMOD factorisation and solve on box
// meshes of about 10k, 30k and 100k nodes; and one simulated second of a
// stiff cube dropped on the ground, Newmark against backward Euler.
#include <benchmark/benchmark.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/tet_mesh.h"
#include "solvers/backward_euler.h"
#include "solvers/newmark.h"
#include "solvers/sparse_cholesky.h"
#include "solvers/sparse_hessian.h"

namespace {

/// Cells per side for about 10k, 30k, 100k nodes ((c + 1)³).
int cells_for(std::int64_t thousands) { return thousands <= 10 ? 21 : thousands <= 30 ? 30 : 46; }

goo::Body stretched_box(int cells) {
  goo::Material m;
  m.youngs_modulus = 1e6;
  m.viscosity = 10.0;
  goo::Body body = goo::make_body(
      goo::make_box_tets(Eigen::Vector3d::Constant(1.0), Eigen::Vector3i::Constant(cells)), m);
  body.positions = body.rest_positions * Eigen::Vector3d(1.1, 0.95, 1.0).asDiagonal();
  return body;
}

struct System {
  goo::Body body;
  goo::SparseHessian hessian;
  std::vector<goo::Matrix12> blocks;
  Eigen::VectorXd diagonal;
};

void assemble(System& s) {
  const goo::Index ne = s.body.num_elements();
  s.blocks.resize(static_cast<std::size_t>(ne));
  tbb::parallel_for(tbb::blocked_range<goo::Index>(0, ne, 512), [&](const tbb::blocked_range<goo::Index>& r) {
    for (goo::Index e = r.begin(); e != r.end(); ++e)
      s.blocks[static_cast<std::size_t>(e)] = goo::element_hessian(goo::IsotropicEnergy(s.body.material), goo::ElementRest::of(s.body, e), goo::element_corners(s.body, s.body.positions, e), true);
  });
  s.hessian.assemble(s.blocks, s.diagonal);
}

System make_system(int cells) {
  System s{stretched_box(cells), {}, {}, {}};
  s.hessian.build(s.body.tets, s.body.num_nodes());
  s.diagonal = Eigen::VectorXd::Zero(3 * s.body.num_nodes());
  for (goo::Index n = 0; n < s.body.num_nodes(); ++n) s.diagonal.segment<3>(3 * n).setConstant(s.body.masses[n] / 1e-4);
  return s;
}

// Args: thousands of nodes.
void BM_AssembleHessian(benchmark::State& state) {
  System s = make_system(cells_for(state.range(0)));
  for (auto _ : state) assemble(s);
  state.counters["nodes"] = s.body.num_nodes();
  state.counters["elements"] = s.body.num_elements();
  state.SetItemsProcessed(state.iterations() * s.body.num_elements());
}
BENCHMARK(BM_AssembleHessian)->Arg(10)->Arg(30)->Arg(100)->Unit(benchmark::kMillisecond)->UseRealTime();

/// Numerical factorisation with the symbolic analysis reused (what a Newton
/// iteration pays).
void BM_CholmodFactor(benchmark::State& state) {
  System s = make_system(cells_for(state.range(0)));
  assemble(s);
  goo::SparseCholesky cholesky;  // as backward Euler factors (one BLAS thread)
  cholesky.analyse(s.hessian.matrix(), 0);
  for (auto _ : state) benchmark::DoNotOptimize(cholesky.factor(s.hessian.matrix(), 0));
  state.counters["unknowns"] = static_cast<double>(s.hessian.matrix().rows());
}
BENCHMARK(BM_CholmodFactor)->Arg(10)->Arg(30)->Arg(100)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_CholmodSolve(benchmark::State& state) {
  System s = make_system(cells_for(state.range(0)));
  assemble(s);
  goo::SparseCholesky cholesky;
  cholesky.analyse(s.hessian.matrix(), 0);
  if (!cholesky.factor(s.hessian.matrix(), 0)) state.SkipWithError("the Hessian is not positive definite");
  const Eigen::VectorXd b = Eigen::VectorXd::Ones(s.hessian.matrix().rows());
  Eigen::VectorXd x;
  for (auto _ : state) {
    cholesky.solve(b, x);
    benchmark::DoNotOptimize(x.data());
  }
  state.counters["unknowns"] = static_cast<double>(s.hessian.matrix().rows());
}
BENCHMARK(BM_CholmodSolve)->Arg(10)->Arg(30)->Arg(100)->Unit(benchmark::kMillisecond)->UseRealTime();

/// One simulated second of a stiff cube (E = 10⁷ Pa, 0.3 m, 6³ cells)
/// dropped from 0.1 m onto the ground. Arg: 0 Newmark at its CFL step,
/// 1 backward Euler at Δt = 1/100 s.
void BM_StiffCubeSecond(benchmark::State& state) {
  goo::Material m;
  m.youngs_modulus = 1e7;
  m.viscosity = 100.0;
  goo::Constraints c;
  c.obstacles.push_back(
      goo::Obstacle{"ground", goo::make_half_space(Eigen::Vector3d::UnitZ(), 0.0), goo::RigidMotion{}, 0.5});
  int steps = 0;
  for (auto _ : state) {
    goo::Body body = goo::make_body(goo::make_box_tets(Eigen::Vector3d::Constant(0.3), Eigen::Vector3i::Constant(6),
                                                       Eigen::Vector3d(0.0, 0.0, 0.1)),
                                    m);
    goo::embed_boundary(body);
    if (state.range(0) == 0) {
      goo::NewmarkIntegrator integrator(goo::NewmarkSettings{}, c);
      steps = integrator.advance_to(body, 1.0);
    } else {
      goo::BackwardEulerSettings settings;
      settings.time_step = 0.01;
      goo::BackwardEulerIntegrator integrator(settings, c);
      steps = integrator.advance_to(body, 1.0);
    }
    benchmark::DoNotOptimize(body.positions.data());
  }
  state.counters["steps"] = steps;
}
BENCHMARK(BM_StiffCubeSecond)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
