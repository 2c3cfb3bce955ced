// Starting at rest: the settling stage that brings a freshly seeded scene into static
// equilibrium under gravity before t = 0 (a snowpack is in equilibrium before anything
// triggers it; a body seeded stress-free under full gravity would bounce, and its dynamic
// overshoot, twice the static load, would fail a weak layer at t = 0).
#pragma once

#include <Eigen/Core>

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

namespace firn {

struct World;

/// How the settling stage ran (summary.json: settle_*).
struct SettleReport {
    bool ran = false;         ///< the scene asked for settling
    bool converged = false;   ///< a kinetic-energy peak fell below tolerance x elastic energy
    bool interrupted = false; ///< SettleParams::interrupted ended it
    double time = 0.0;        ///< simulated settling time, s
    long long steps = 0;      ///< settling steps
    double wallSeconds = 0.0;
    int kineticResets = 0;      ///< times the velocities were zeroed at a kinetic-energy peak
    double lastPeakRatio = 0.0; ///< last kinetic-energy peak / elastic energy
    std::size_t overloaded = 0; ///< particles whose settled static stress exceeds their strength
    /// Their bounding box, m, in the scene's coordinates (the local frame's origin added, as
    /// every output does: a DEM scene's box is in the DEM's coordinates).
    Eigen::Vector3d overloadedMin = Eigen::Vector3d::Zero();
    Eigen::Vector3d overloadedMax = Eigen::Vector3d::Zero();
    /// Of them, how many of each material, by the material's index in the scene.
    std::vector<std::size_t> overloadedByMaterial;
    /// One sentence on what happened, naming where the static load exceeds the strength.
    std::string message;
};

/// Where settling stands after a step, for a progress line.
struct SettleProgress {
    double time = 0.0;          ///< simulated settling time so far, s
    long long steps = 0;        ///< settling steps so far
    int kineticResets = 0;      ///< kinetic-energy peaks passed so far
    double lastPeakRatio = 0.0; ///< the last peak / elastic energy (0 before the first)
};

/// Settling parameters (SimulationDesc::settle*).
struct SettleParams {
    double maxTime = 2.0;    ///< s
    double tolerance = 1e-6; ///< kinetic-energy peak / elastic energy that counts as at rest
    double cfl = 0.4;        ///< CFL number of the settling steps (settlingCfl)
    /// Polled every step: true ends settling early (a signal asked the run to stop).
    std::function<bool()> interrupted;
    /// Called after every step when set (firn run's progress line throttles it).
    std::function<void(const SettleProgress&)> progress;
    /// The materials' names, by index, for the overload message ("519 of weak"); a material
    /// without one is named by its number in the scene ("material 2").
    std::vector<std::string> materialNames;
};

/// The CFL number of the settling steps when the scene gives none. Settling is elastic APIC,
/// which the stability study (bench/README.md, bench/results/stability/) found stable up to CFL
/// 0.7 at every particle density (1, 4 and 9 per cell, a stiff block dropped on the ground and a
/// snow slab) and up to 1.0 only with two or more particles per cell along each axis; at 1.0 a
/// granular box settling on a plane at 4 per cell went unstable after 1 015 steps
/// (tests/checkpoint_test.cc's round trip). The static equilibrium hardly depends on the step
/// (tests/validation/settle_test.cc).
constexpr double kSettlingCfl = 0.7;

/// The CFL number settling steps at: the scene's simulation.settle_cfl when given (> 0), else
/// kSettlingCfl, or the scene's own grid.cfl when that is larger.
double settlingCfl(double givenSettleCfl, double sceneCfl);

/// How a material is named in settling's report and summary: its scene name, or "material N"
/// (N from 1, in scene order) when it has none.
std::string materialLabel(const std::vector<std::string>& names, std::size_t index);

/// Dynamic relaxation of the world under full gravity (Cundall's kinetic damping: every time
/// the total kinetic energy passes a peak, all velocities are set to zero, which removes the
/// energy of the slowest mode at its equilibrium crossing). During settling every material is
/// elastic (nothing can fail while it loads) and the ground is sticky, whatever its boundary
/// condition (a block on a slope steeper than its friction angle, or on a slip plane, settles in
/// place and starts to slide at t = 0); walls (planes facing sideways) keep theirs. The transfer
/// is APIC whatever the scene's (the equilibrium does not depend on it; FLIP's particle noise and
/// PIC's overdamped creep delay the kinetic-energy peaks). Ends
/// when a kinetic-energy peak is below `tolerance` x the elastic energy, or after `maxTime`.
/// Afterwards velocities are zero, time and step count restart at 0, the materials' plasticity
/// is applied once to the settled stress, and the particles it yields are reported: their
/// static load exceeds their strength. Throws SimulationError if settling goes unstable.
SettleReport settleUnderGravity(World& world, const SettleParams& params);

} // namespace firn
