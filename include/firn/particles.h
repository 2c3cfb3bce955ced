// The particle store: structure-of-arrays state, bucketed by grid leaf.
//
// Particles are kept sorted by the 8^d block ("leaf", as in an OpenVDB tree) that holds their
// quadratic B-spline base node, floor(x/dx - 1/2). Each leaf's particles are contiguous, the
// same layout a PointDataGrid leaf gives its attribute arrays, so that P2G and G2P run per leaf
// with TBB and write only leaf-owned memory. Frames are exported to a PointDataGrid by io.
#pragma once

#include <firn/material.h>

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

namespace firn {

using Mat3f = Eigen::Matrix3f;
/// Block (leaf) coordinate: node index >> 3 on each axis; z is 0 in 2D.
using LeafKey = std::array<int, 3>;
constexpr int kLeafLog2 = 3;
constexpr int kLeafDim = 1 << kLeafLog2;

/// Symmetric 3x3 matrix (Kirchhoff stress): xx, yy, zz, xy, xz, yz.
struct Sym3f {
    float xx = 0.f, yy = 0.f, zz = 0.f, xy = 0.f, xz = 0.f, yz = 0.f;
    Vec3f times(const Vec3f& a) const {
        return {xx * a[0] + xy * a[1] + xz * a[2], xy * a[0] + yy * a[1] + yz * a[2],
                xz * a[0] + yz * a[1] + zz * a[2]};
    }
};

struct ParticleSet {
    int dim = 3;
    float dx = 0.05f;

    std::vector<Vec3f> x; ///< position, m
    std::vector<Vec3f> v; ///< velocity, m/s
    std::vector<Mat3f> C; ///< APIC affine velocity gradient, 1/s
    /// Elastic displacement gradient H = Fe - I (Fe: elastic deformation gradient). Stored
    /// instead of Fe because snow at rest has strains of 1e-4..1e-3 and changes them by 1e-9 a
    /// step: in Fe (entries near 1, float spacing 1.2e-7) those increments round away, biased
    /// towards the larger ones, and a resting body gains energy every step (docs/validation.md).
    std::vector<Mat3f> H;
    std::vector<Sym3f> tau;             ///< Kirchhoff stress after the last plasticity pass, Pa
    std::vector<float> mass;            ///< kg (2D: per metre of depth)
    std::vector<float> volume0;         ///< initial volume, m^3 (2D: m^2)
    std::vector<std::int32_t> material; ///< index into the world's materials
    std::vector<PlasticState> plastic;

    std::vector<LeafKey> leaves;          ///< sorted, unique, non-empty
    std::vector<std::uint32_t> leafStart; ///< leaves.size() + 1 offsets into the arrays
    /// Per leaf, for sleeping: steps its particles have all been slow (carried over by key
    /// through re-bucketing) and how deep it sleeps (set by the sleep pass, SleepLevel).
    std::vector<std::uint16_t> leafQuietSteps;
    std::vector<std::uint8_t> leafSleep;
    /// Per asleep leaf: the mean grid velocity of its block in the last step, i.e. what the
    /// forces on the frozen snow would add to its velocity in one step (a load that changed).
    std::vector<Vec3f> leafPush;
    /// Per leaf: the mean velocity of its awake particles when its quiet steps began; a leaf
    /// whose mean velocity has since changed faster than kWakeAcceleration is not at rest.
    std::vector<Vec3f> leafQuietVelocity;

    std::size_t size() const { return x.size(); }
    bool asleep(std::size_t i) const { return plastic[i].flags & kFlagAsleep; }
    /// How deep a leaf sleeps: awake (some particle awake), asleep (all), interior (it and its
    /// neighbours: nothing awake reads its push), deep (all within two leaves: nothing awake
    /// reads the nodes it scatters to, so it skips P2G too).
    enum SleepLevel : std::uint8_t { kAwake = 0, kAsleep = 1, kInterior = 2, kDeep = 3 };
    SleepLevel leafSleepLevel(std::size_t leaf) const {
        return leaf < leafSleep.size() ? SleepLevel(leafSleep[leaf]) : kAwake;
    }
    /// Elastic deformation gradient Fe = I + H of particle i (rounded to float).
    Mat3f deformationGradient(std::size_t i) const { return Mat3f::Identity() + H[i]; }
    /// Kirchhoff stress of particle i, asleep or awake.
    Sym3f stress(std::size_t i) const {
        if (!asleep(i)) return tau[i];
        const Mat3f& s = C[i];
        return Sym3f{s(0, 0), s(1, 1), s(2, 2), s(0, 1), s(0, 2), s(1, 2)};
    }
    std::size_t leafCount() const { return leaves.size(); }

    /// Appends one particle at rest, undeformed (H = 0) (leaves are rebuilt by bucketByLeaf).
    void add(const Vec3f& position, const Vec3f& velocity, float particleMass, float volume,
             int materialIndex, const PlasticState& state);
    /// Sorts particles into leaves (stable, deterministic for any thread count). Cheap when
    /// few particles change leaf, which is the common case at CFL-limited steps. Leaves `tau`
    /// undefined (its bytes are the sort's scratch): recompute it (applyPlasticity) before the
    /// next P2G.
    void bucketByLeaf();
    /// Allocates room for n particles in every array.
    void reserve(std::size_t n);
    /// Moves the particles whose plastic flags have any bit of `flags` into a new set (their
    /// order kept) and compacts this one in place (it keeps its capacity, so appending them
    /// back needs no new memory). Both need bucketByLeaf before the next step.
    ParticleSet extractFlagged(std::uint32_t flags);
    /// Moves every particle of `other` to the end of this set (unbucketed: call bucketByLeaf).
    void append(ParticleSet&& other);
};

/// Block of the base node of a particle at x (quadratic B-spline stencil base).
LeafKey leafOf(const Vec3f& x, float invDx, int dim);

} // namespace firn
