// Particle <-> grid transfers with quadratic B-splines: APIC (Jiang et al. 2015), PIC, the
// PIC/FLIP blend, and XPIC(m) (Hammerquist & Nairn 2017). Stress enters P2G through the MLS-MPM
// form of the force (Hu et al. 2018): the nodal impulse -dt V0 tau grad w uses grad w = w D^-1 (x_i
// - x_p), which is exact for the affine part of quadratic B-splines and lets momentum and force
// share one affine matrix.
//
// Parallel over particle leaves with TBB and without atomics or locks: each particle leaf
// scatters into its own padded 10^d block, then each grid leaf sums the (up to 2^d) padded
// blocks that overlap it, in a fixed order. Sums therefore have the same order whatever the
// thread count: results are bitwise reproducible.
#pragma once

#include <firn/grid.h>
#include <firn/io.h>
#include <firn/particles.h>
#include <firn/scene.h>

#include <vector>

namespace firn {

struct TransferParams {
    int dim = 3;
    float dx = 0.05f;
    float dt = 1e-3f;
    Transfer transfer = Transfer::Apic;
    float flipBlend = 0.95f;
    /// With a slip surface (World::slipMaterial >= 0) particles flagged kFlagUpperField scatter
    /// to and read from the upper field; particles of this material tell whether the layer under
    /// a node still bonds the fields. -1: one field.
    int slipMaterial = -1;
    int xpicOrder = 2; ///< XPIC(m)'s m; 1 is PIC
};

/// FLIP and XPIC update particle velocities from a grid reference (Grid::aux channel 0..2).
inline bool keepsReference(Transfer transfer) {
    return transfer == Transfer::Flip || transfer == Transfer::Xpic;
}

/// Per node channels of Grid::aux: the FLIP reference velocity of the (lower) field, and with a
/// slip surface the upper field's mass, momentum (velocity after the update), FLIP reference and
/// bond (1 where the weak layer's mass at the node is mostly uncollapsed, else 0).
struct AuxLayout {
    bool flip = false;
    bool twoFields = false;
    int lowerReference() const { return 0; }
    int upperMass() const { return flip ? 3 : 0; }
    int upperVelocity() const { return upperMass() + 1; }
    int upperReference() const { return upperVelocity() + 3; }
    int bond() const { return upperVelocity() + (flip ? 6 : 3); }
    int channels() const { return twoFields ? bond() + 1 : (flip ? 3 : 0); }
};

/// The nodes of a leaf's padded block (10^d nodes, the leaf's 8 and two more along each axis)
/// that its particles' stencils reach, per axis lo..hi inclusive; empty when lo > hi.
struct NodeBox {
    int lo[3] = {1 << 20, 1 << 20, 1 << 20};
    int hi[3] = {-1, -1, -1};
    bool empty() const { return lo[0] > hi[0]; }
};

/// The scatter phase's padded blocks, one per particle leaf, and the nodes each one reached:
/// only those are zeroed and merged.
struct PaddedBlocks {
    std::vector<float> values;
    std::vector<NodeBox> boxes;
};

/// Reusable per-leaf padded blocks of the scatter phase.
struct TransferScratch {
    PaddedBlocks padded;
    std::vector<float> xpicTerm, xpicSum; ///< XPIC's grid fields, 3 per node
    std::vector<Vec3f> xpicAtParticles;   ///< XPIC's grid term interpolated to the particles
};

/// P2G: grid mass, momentum plus stress impulse (APIC, PIC) in Grid::velocity; for FLIP the
/// stress impulse goes to Grid::aux (3 channels) so that the transferred velocity stays apart.
/// With a slip surface the lower field goes there and the upper field to Grid::aux (AuxLayout);
/// the grid must be rebuilt with AuxLayout::channels().
void particlesToGrid(const ParticleSet& particles, Grid& grid, const TransferParams& params,
                     TransferScratch& scratch);

/// XPIC(m), after P2G: v* = sum_{k<m} (I - S+ S)^k v^L into the scratch, with S grid to
/// particles, S+ mass-weighted particles to grid and v^L = S+ v_p P2G's grid velocity.
void xpicProjection(const ParticleSet& particles, const Grid& grid, const TransferParams& params,
                    TransferScratch& scratch);

/// XPIC(m), after the grid update: the reference in Grid::aux, v^L, becomes v^L - v*, so that
/// G2P's increment S (v - reference) is XPIC's particle velocity S v* + S (v - v^L): FLIP's
/// update with the particle velocity replaced by its filtered S v* (m = 1: S v^L, PIC).
void subtractXpicProjection(Grid& grid, const TransferScratch& scratch);

/// G2P: particle velocity (APIC/PIC/FLIP/XPIC), affine matrix C (the velocity gradient, also used
/// for F), position x += dt v_pic and trial F = (I + dt C) F. Returns the largest speed.
float gridToParticles(ParticleSet& particles, const Grid& grid, const TransferParams& params);

/// The largest float s whose square root (std::sqrt, rounded) is at most kMovedSpeed: for every
/// float s, std::sqrt(s) > kMovedSpeed exactly when s > this bound, the root being monotone. G2P
/// flags moving snow from squared speeds, without a root per particle.
float movedSpeedSquaredBound();

/// Rasterises mass, velocity and failed mass fraction of the particles onto the grid's leaves
/// with the same weights as P2G, for the volume cache. Grid must be rebuilt for `particles`.
VolumeFrame rasterizeVolumes(const ParticleSet& particles, const Grid& grid,
                             TransferScratch& scratch);

} // namespace firn
