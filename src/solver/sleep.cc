// Sleeping: resting snow skips G2P and plasticity, as Houdini's MPM "auto sleep" does. The
// unit is the particle leaf (8^d nodes): a leaf whose particles, and its neighbours', have all
// been slower than sleepSpeed for sleepSteps steps goes to sleep; any particle at or above that
// speed in a leaf or its neighbours wakes it, and so does a grid that accelerates the frozen
// snow (a load that changed, a gravity ramp). Asleep particles still scatter their mass and
// frozen stress in P2G, so the deposit keeps carrying the snow around it, and a moving neighbour
// wakes it one step after it starts pushing.
#include <firn/solver.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>

namespace firn {
namespace {

struct LeafMotion {
    float maxSpeed = 0.f;               ///< over the awake particles
    Vec3f meanVelocity = Vec3f::Zero(); ///< of the awake particles
    bool anyAsleep = false;
    bool anyAwake = false;
    bool pushed = false; ///< asleep, and the grid accelerates it (its load changed)
};

/// Indices of the existing neighbour leaves (3^dim - 1 offsets) of every leaf.
std::vector<std::vector<std::uint32_t>> neighbourLeaves(const ParticleSet& ps) {
    const std::size_t nl = ps.leafCount();
    const int nz = ps.dim == 3 ? 1 : 0;
    std::vector<std::vector<std::uint32_t>> out(nl);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nl, 64), [&](const auto& r) {
        for (std::size_t l = r.begin(); l != r.end(); ++l) {
            for (int dx = -1; dx <= 1; ++dx)
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dz = -nz; dz <= nz; ++dz) {
                        if (!dx && !dy && !dz) continue;
                        const LeafKey k = {ps.leaves[l][0] + dx, ps.leaves[l][1] + dy,
                                           ps.leaves[l][2] + dz};
                        const auto it = std::lower_bound(ps.leaves.begin(), ps.leaves.end(), k);
                        if (it != ps.leaves.end() && *it == k)
                            out[l].push_back(static_cast<std::uint32_t>(it - ps.leaves.begin()));
                    }
        }
    });
    return out;
}

/// Raises leaves at `level` whose neighbours are all at `level` or deeper to `deeper`, from a
/// snapshot, so the result does not depend on the visiting order.
void deepen(ParticleSet& ps, const std::vector<std::vector<std::uint32_t>>& neighbours,
            std::uint8_t level, std::uint8_t deeper) {
    const std::vector<std::uint8_t> before = ps.leafSleep;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, before.size(), 64), [&](const auto& r) {
        for (std::size_t l = r.begin(); l != r.end(); ++l) {
            if (before[l] != level) continue;
            bool all = true;
            for (std::uint32_t n : neighbours[l]) all &= before[n] >= level;
            if (all) ps.leafSleep[l] = deeper;
        }
    });
}

Mat3f toMatrix(const Sym3f& t) {
    Mat3f m;
    m << t.xx, t.xy, t.xz, t.xy, t.yy, t.yz, t.xz, t.yz, t.zz;
    return m;
}

} // namespace

void updateSleep(World& world, float dt) {
    ParticleSet& ps = world.particles;
    const std::size_t nl = ps.leafCount();
    if (!world.sleep || nl == 0) return;
    if (ps.leafQuietSteps.size() != nl) ps.leafQuietSteps.assign(nl, 0);
    if (ps.leafPush.size() != nl) ps.leafPush.assign(nl, Vec3f::Zero());
    if (ps.leafQuietVelocity.size() != nl) ps.leafQuietVelocity.assign(nl, Vec3f::Zero());
    const std::uint16_t needed = static_cast<std::uint16_t>(std::min(world.sleepSteps, 65535));
    ps.leafSleep.assign(nl, ParticleSet::kAwake);

    std::vector<LeafMotion> motion(nl);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nl, 16), [&](const auto& r) {
        for (std::size_t l = r.begin(); l != r.end(); ++l) {
            LeafMotion& m = motion[l];
            int awake = 0;
            for (std::uint32_t i = ps.leafStart[l]; i < ps.leafStart[l + 1]; ++i) {
                if (ps.asleep(i)) {
                    m.anyAsleep = true;
                } else {
                    m.anyAwake = true;
                    m.maxSpeed = std::max(m.maxSpeed, ps.v[i].norm());
                    m.meanVelocity += ps.v[i];
                    ++awake;
                }
            }
            if (awake) m.meanVelocity /= float(awake);
            // Only leaves next to awake snow watch their push (SleepLevel): deeper ones leave
            // it at zero and are woken through their neighbours.
            m.pushed = ps.leafPush[l].norm() > kWakeAcceleration * dt;
            // While gravity ramps up the load is changing: nothing counts as at rest.
            const bool ramping = world.time < world.gravityRamp;
            const bool slow = m.maxSpeed < world.sleepSpeed && !ramping;
            std::uint16_t& quiet = ps.leafQuietSteps[l];
            Vec3f& start = ps.leafQuietVelocity[l];
            if (!slow) {
                quiet = 0;
            } else {
                const int next = std::min<int>(quiet + 1, 65535);
                // Snow that starts to fail from rest (a column beyond its strength) is slow
                // for its first steps: at rest also means not accelerating, judged over the
                // whole quiet window so that the noise of single steps averages out.
                const bool accelerating =
                    m.anyAwake && next >= needed &&
                    (m.meanVelocity - start).norm() > kWakeAcceleration * dt * float(next);
                const bool restart = quiet == 0 || accelerating;
                if (restart) start = m.meanVelocity;
                quiet = static_cast<std::uint16_t>(restart ? 1 : next);
            }
        }
    });
    if (world.sleepNeighbours.leaves != ps.leaves) {
        world.sleepNeighbours.of = neighbourLeaves(ps);
        world.sleepNeighbours.leaves = ps.leaves;
    }
    const auto& neighbours = world.sleepNeighbours.of;
    // Decisions read only this step's motion and counters, so they do not depend on the order
    // in which leaves are visited: the same for any thread count.
    std::vector<std::uint8_t> woken(nl, 0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nl, 16), [&](const auto& r) {
        for (std::size_t l = r.begin(); l != r.end(); ++l) {
            bool moving = motion[l].maxSpeed >= world.sleepSpeed;
            bool allQuiet = ps.leafQuietSteps[l] >= needed;
            for (std::uint32_t n : neighbours[l]) {
                moving |= motion[n].maxSpeed >= world.sleepSpeed;
                allQuiet &= ps.leafQuietSteps[n] >= needed;
            }
            const bool wake = (moving || motion[l].pushed) && motion[l].anyAsleep;
            const bool fallAsleep = !moving && allQuiet && motion[l].anyAwake;
            woken[l] = wake;
            // A leaf that neither wakes nor falls asleep changes no particle: skip the pass.
            for (std::uint32_t i = ps.leafStart[l]; (wake || fallAsleep) && i < ps.leafStart[l + 1];
                 ++i) {
                PlasticState& s = ps.plastic[i];
                if (wake && (s.flags & kFlagAsleep)) {
                    ps.tau[i] = ps.stress(i);
                    ps.C[i].setZero();
                    s.flags &= ~kFlagAsleep;
                } else if (fallAsleep && !(s.flags & kFlagAsleep)) {
                    ps.C[i] = toMatrix(ps.tau[i]); // kFlagAsleep: C holds the frozen stress
                    ps.v[i].setZero();
                    s.flags |= kFlagAsleep;
                }
            }
            const bool asleep = !wake && (fallAsleep || !motion[l].anyAwake);
            ps.leafSleep[l] = asleep ? ParticleSet::kAsleep : ParticleSet::kAwake;
            if (!asleep) ps.leafPush[l].setZero();
        }
    });
    deepen(ps, neighbours, ParticleSet::kAsleep, ParticleSet::kInterior);
    deepen(ps, neighbours, ParticleSet::kInterior, ParticleSet::kDeep);
    // A woken leaf must be quiet for sleepSteps again before it may sleep.
    for (std::size_t l = 0; l < nl; ++l) {
        if (woken[l]) ps.leafQuietSteps[l] = 0;
    }
}

std::size_t asleepCount(const World& world) {
    const ParticleSet& ps = world.particles;
    return tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, ps.size(), 4096), std::size_t(0),
        [&](const auto& r, std::size_t n) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) n += ps.asleep(i) ? 1 : 0;
            return n;
        },
        [](std::size_t a, std::size_t b) { return a + b; });
}

} // namespace firn
