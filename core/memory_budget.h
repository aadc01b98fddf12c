#pragma once
// What a scene will need in memory, estimated before anything is allocated,
// against what this process may use: a scene that cannot fit is refused
// naming the field that makes it big, instead of failing with bad_alloc
// minutes later (docs/running.md, "Memory").
#include <cstdint>
#include <string>

namespace goo {

/// Bytes this process may use: GOO_MEMORY_LIMIT when set (bytes, or with a
/// K, M, G or T suffix), else the machine's physical memory, or its control
/// group's limit when lower. Throws goo::Error for a GOO_MEMORY_LIMIT that is
/// not a size.
[[nodiscard]] std::uint64_t memory_limit_bytes();

/// Keeps the memory this process frees for its next allocations instead of
/// handing it back to the system (glibc's malloc: blocks up to 32 MB from
/// the heap, whose free top is kept up to 1 GB). A re-mesh allocates and
/// frees the same tens of megabytes each time, and a page fresh from the
/// system costs about 11 µs on the 2-vCPU machine of docs/benchmarks.md:
/// `BM_Remesh/0/20` took 167 and 162 ms a re-mesh with glibc's defaults and
/// 129 and 128 ms with this (medians of 5, two rounds). The goo command and goo_bench call it first thing; results do
/// not depend on it. Does nothing with another allocator (the sanitizers').
void keep_freed_memory();

/// "12.3 GB": a byte count for messages.
[[nodiscard]] std::string format_bytes(double bytes);

/// Setting a body up (meshing, embedding, exact masses, frame 0 written)
/// costs at least this much per surface triangle, per finite element, and
/// per cell of the lattice's bounding block (dense per-cell arrays of the
/// voxeliser and the mesh builder). Measured at frame 0 of release builds
/// (a sphere of 0.25M to 4M triangles: 357-431 B; boxes of 0.1M to 2.8M
/// elements: 302-317 B; 1 + 4 bytes per node and per tet key, 2 nodes and 12
/// keys a cell); stepping needs more.
inline constexpr double kSetupBytesPerTriangle = 350.0;
inline constexpr double kSetupBytesPerElement = 300.0;
inline constexpr double kSetupBytesPerLatticeCell = 70.0;

/// The most lattice cells a body's block may have: its 12 tetrahedron keys
/// a cell are 32-bit indices.
inline constexpr double kMaxLatticeCells = 2147483647.0 / 12.0;

}  // namespace goo
