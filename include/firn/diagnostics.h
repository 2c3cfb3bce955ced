// Per-frame measurements computed from the world (never changing it): conservation checks,
// energies, front and crack tip. Sums run per leaf and are added in leaf order, so they are the
// same for any thread count.
#pragma once

#include <firn/solver.h>

namespace firn {

struct FrameDiagnostics {
    std::size_t particles = 0;
    double mass = 0; ///< kg (2D: per metre)
    Eigen::Vector3d centreOfMass = Eigen::Vector3d::Zero();
    Eigen::Vector3d momentum = Eigen::Vector3d::Zero();
    double kineticEnergy = 0;       ///< J
    double elasticEnergy = 0;       ///< J, Hencky energy of the elastic strains
    double gravitationalEnergy = 0; ///< J, -sum m g.x
    double maxSpeed = 0;            ///< m/s
    double topX = 0, topY = 0;      ///< highest particle, m
    double frontX = std::numeric_limits<double>::quiet_NaN(); ///< max x of moving snow (> 0.1 m/s)
    bool hasWeakLayer = false;
    /// Extent along x of weak-layer particles with eta > 0; NaN while none.
    double crackMinX = std::numeric_limits<double>::quiet_NaN();
    double crackMaxX = std::numeric_limits<double>::quiet_NaN();
    double failedFraction = 0;                               ///< failed mass / mass
    bool finite = true;                                      ///< every position and velocity finite
    Eigen::Vector3d worstPosition = Eigen::Vector3d::Zero(); ///< where the fastest or first
                                                             ///< non-finite particle is
    double totalEnergy() const { return kineticEnergy + elasticEnergy + gravitationalEnergy; }
};

FrameDiagnostics computeDiagnostics(const World& world);

/// Particle attributes of outputs.md for the particle cache (p, q from the stored Kirchhoff
/// stress as defined in the paper).
ParticleFrame exportParticles(const World& world);

} // namespace firn
