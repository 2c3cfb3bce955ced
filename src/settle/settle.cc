// The settling stage (include/firn/settle.h): dynamic relaxation with kinetic damping.
#include <firn/diagnostics.h>
#include <firn/errors.h>
#include <firn/settle.h>
#include <firn/solver.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

namespace firn {

namespace {

double kineticEnergy(const ParticleSet& ps) {
    double e = 0.0;
    for (std::size_t i = 0; i < ps.size(); ++i)
        e += 0.5 * double(ps.mass[i]) * ps.v[i].squaredNorm();
    return e;
}

void stopAll(ParticleSet& ps) {
    std::fill(ps.v.begin(), ps.v.end(), Vec3f::Zero());
    std::fill(ps.C.begin(), ps.C.end(), Mat3f::Zero());
}

/// What the world looks like while it settles: elastic materials, the ground (terrain that
/// carries weight) sticky (held at rest where it is not sticky in the scene: the equilibrium
/// of friction that sticks), walls as they are, full gravity, nothing asleep, and the APIC
/// transfer. The static equilibrium does not depend on the transfer, but the kinetic damping's
/// speed does: FLIP keeps particle velocities the grid does not see, whose kinetic energy grows
/// without a peak after each reset (the 3D slope with its snowman: 1.60 s of settling, 6 912
/// steps, against 0.52 s, 2 236 steps with APIC; 4 973 and 4 970 particles overloaded), and
/// PIC's damping turns the slowest mode into a creep that each reset shortens by only ~45 %
/// (a 1 m slice of it: 20 resets over 1.0 s against APIC's 9 over 0.29 s). Restored on
/// destruction, so that an exception leaves the world as the scene describes it. The step's CFL
/// number is settling's own (settlingCfl).
class SettlingConditions {
public:
    SettlingConditions(World& w, double cfl)
        : mWorld(w)
        , mMaterials(w.materials)
        , mColliders(w.colliders)
        , mSleep(w.sleep)
        , mGravityRamp(w.gravityRamp)
        , mTransfer(w.transfer)
        , mCfl(w.cfl) {
        for (Material& m : w.materials) m.model = MaterialModel::Elastic;
        for (Collider& c : w.colliders)
            if (c.carriesWeight(w.gravity)) c = c.heldAtRest();
        w.sleep = false;
        w.gravityRamp = 0.f;
        w.transfer = Transfer::Apic;
        w.cfl = float(cfl);
    }
    ~SettlingConditions() {
        mWorld.materials = mMaterials;
        mWorld.colliders = mColliders;
        mWorld.sleep = mSleep;
        mWorld.gravityRamp = mGravityRamp;
        mWorld.transfer = mTransfer;
        mWorld.cfl = mCfl;
    }
    SettlingConditions(const SettlingConditions&) = delete;
    SettlingConditions& operator=(const SettlingConditions&) = delete;

private:
    World& mWorld;
    std::vector<Material> mMaterials;
    std::vector<Collider> mColliders;
    bool mSleep;
    float mGravityRamp;
    Transfer mTransfer;
    float mCfl;
};

std::string formatCfl(double cfl) {
    std::ostringstream out;
    out << cfl;
    return out.str();
}

std::string formatBox(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int dim) {
    std::ostringstream out;
    out.precision(3);
    const char* axes = "xyz";
    for (int a = 0; a < dim; ++a)
        out << (a ? ", " : "") << axes[a] << " in [" << lo[a] << ", " << hi[a] << "] m";
    return out.str();
}

/// Applies plasticity to the settled stress and reports the particles that yield: there the
/// static load exceeds the strength. Their failed flag stays: they fail at t = 0, as they would
/// in the first step.
void reportOverload(World& w, const std::vector<std::string>& names, SettleReport& report) {
    ParticleSet& ps = w.particles;
    for (PlasticState& s : ps.plastic) s.flags &= ~kFlagFailed;
    applyPlasticity(w, w.time);
    report.overloadedByMaterial.assign(w.materials.size(), 0);
    const Eigen::Vector3d origin(w.origin[0], w.origin[1], w.origin[2]);
    for (std::size_t i = 0; i < ps.size(); ++i) {
        if (!(ps.plastic[i].flags & kFlagFailed) || (ps.plastic[i].flags & kFlagInCut)) continue;
        const Eigen::Vector3d x = ps.x[i].cast<double>() + origin; // scene coordinates
        if (report.overloaded == 0) report.overloadedMin = report.overloadedMax = x;
        report.overloadedMin = report.overloadedMin.cwiseMin(x);
        report.overloadedMax = report.overloadedMax.cwiseMax(x);
        ++report.overloaded;
        ++report.overloadedByMaterial[std::size_t(ps.material[i])];
    }
    if (report.overloaded == 0) return;
    std::ostringstream why;
    why << report.overloaded << " particles carry a static load beyond their strength and yield at "
        << "t = 0 (";
    bool first = true;
    for (std::size_t m = 0; m < report.overloadedByMaterial.size(); ++m) {
        if (!report.overloadedByMaterial[m]) continue;
        why << (first ? "" : ", ") << report.overloadedByMaterial[m] << " of "
            << materialLabel(names, m);
        first = false;
    }
    why << "), within " << formatBox(report.overloadedMin, report.overloadedMax, w.dim);
    report.message = why.str();
}

} // namespace

double settlingCfl(double givenSettleCfl, double sceneCfl) {
    if (givenSettleCfl > 0.0) return givenSettleCfl;
    return std::max(sceneCfl, kSettlingCfl);
}

std::string materialLabel(const std::vector<std::string>& names, std::size_t index) {
    if (index < names.size() && !names[index].empty()) return names[index];
    return "material " + std::to_string(index + 1);
}

SettleReport settleUnderGravity(World& w, const SettleParams& params) {
    const auto start = std::chrono::steady_clock::now();
    SettleReport report;
    report.ran = true;
    if (w.particles.size() == 0) { // nothing rests on the terrain: nothing to settle
        report.converged = true;
        return report;
    }
    {
        SettlingConditions conditions(w, params.cfl);
        applyPlasticity(w, w.time); // elastic stress of the seeded state
        double previous = 0.0;
        while (w.time < params.maxTime) {
            if (params.interrupted && params.interrupted()) {
                report.interrupted = true;
                break;
            }
            step(w, stableTimeStep(w));
            if (!std::isfinite(w.maxSpeed))
                throw SimulationError("settling went unstable at t = " + std::to_string(w.time) +
                                      " s of settling (" + std::to_string(w.steps) +
                                      " steps at CFL " + formatCfl(params.cfl) +
                                      "; a smaller simulation.settle_cfl steps more gently)");
            if (params.progress)
                params.progress({w.time, w.steps, report.kineticResets, report.lastPeakRatio});
            const double kinetic = kineticEnergy(w.particles);
            if (kinetic == 0.0) { // nothing moves at all: no load, or exactly in equilibrium
                report.converged = true;
                break;
            }
            if (kinetic >= previous) {
                previous = kinetic;
                continue;
            }
            // Past a peak of the kinetic energy: the slowest mode crosses its equilibrium.
            stopAll(w.particles);
            ++report.kineticResets;
            const double elastic = computeDiagnostics(w).elasticEnergy;
            report.lastPeakRatio = elastic > 0.0 ? previous / elastic : 0.0;
            previous = 0.0;
            if (report.lastPeakRatio <= params.tolerance) {
                report.converged = true;
                break;
            }
        }
    }
    report.time = w.time;
    report.steps = w.steps;
    stopAll(w.particles);
    for (PlasticState& s : w.particles.plastic) s.flags &= ~kFlagMoved; // settling is not motion
    w.time = 0.0;
    w.steps = 0;
    // A slab that fractured (or a weak layer that cracked) while settling did so at t = 0.
    for (PlasticState& s : w.particles.plastic) s.fractureTime = 0.f;
    w.maxSpeed = 0.f;
    reportOverload(w, params.materialNames, report);
    if (!report.converged && !report.interrupted) {
        std::ostringstream why;
        why << "not at rest after settle_max_time = " << params.maxTime << " s (last kinetic "
            << "energy peak " << report.lastPeakRatio << " of the elastic energy)"
            << (report.message.empty() ? "" : "; ") << report.message;
        report.message = why.str();
    }
    report.wallSeconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return report;
}

} // namespace firn
