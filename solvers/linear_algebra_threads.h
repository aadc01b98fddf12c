#pragma once
// CHOLMOD calls BLAS (OpenBLAS on Debian), which starts its own threads;
// together with TBB's workers they oversubscribe the cores (measured here:
// a 32k-unknown factorisation took 10 s of wall time for 1.1 s of CPU).
// goo sets the BLAS and OpenMP thread counts once, next to TBB's.

namespace goo {

/// Sets the thread count of OpenBLAS and of OpenMP, if they are loaded
/// (looked up at run time: the BLAS behind libblas.so.3 is Debian's choice).
/// Returns whether OpenBLAS was found.
bool set_linear_algebra_threads(int threads);

}  // namespace goo
