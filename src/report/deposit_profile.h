// Snow depth along the path from one particle frame: at the start the snowpack and the release,
// at the end the deposit (Gaume et al. 2019 chart the deposit along their paths).
#pragma once

#include <firn/io.h>

#include <vector>

namespace firn::report {

/// One cell of dx along x that holds snow.
struct DepthCell {
    double x = 0;     ///< cell centre, m
    double depth = 0; ///< vertical depth of the snow, m (see snowDepthAlongX)
};

/// The snow's vertical depth along x on cells of `dx`, sorted by x: the volume of the cell's
/// particles as seeded (each dx^dimension / particlesPerCell: seeding gives every particle that
/// volume) per unit length along x and, in 3D, per unit width of snow there (the z cells of dx
/// that hold particles at that x). Densification since seeding is not counted, so a deposit
/// reads as deep as its snow was thick at the start; a layer of thickness h on a slope of angle
/// theta reads h / cos(theta).
std::vector<DepthCell> snowDepthAlongX(const ParticleFrame& frame, double dx, int dimension,
                                       int particlesPerCell);

} // namespace firn::report
