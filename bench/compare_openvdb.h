// Our P2G against OpenVDB's points::rasterizeTrilinear on the same particles.
#pragma once

#include <firn/particles.h>

#include <cstddef>

namespace firn::bench {

struct RasterComparison {
    std::size_t particles = 0;
    double openvdbSeconds = 0; ///< per rasterisation: trilinear, 8 voxels per particle, vec3
    double firnSeconds = 0;    ///< per P2G: quadratic APIC, 27 nodes, mass + momentum + stress
    std::size_t openvdbVoxels = 0;
};

/// Builds a PointDataGrid (P, v) from the particles and times both rasterisations, averaged
/// over `repetitions`, with the thread count in force.
RasterComparison compareWithOpenvdb(const ParticleSet& particles, int repetitions);

} // namespace firn::bench
