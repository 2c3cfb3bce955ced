// Slab fractures and slab blocks, frame by frame (Gaume et al. 2019, sec. 3: tensile slab
// fractures behind the weak-layer crack tip, "en-echelon" fractures, Figs. 3, 5 and A1; the
// granulation of the released slab). Reads particle states and never changes them.
//
// A slab particle (Material::slab: snow on a weak layer) is fractured once slabFractured() held for
// it; the solver stamps the time (PlasticState::fractureTime). Along the bed, slab particles are
// binned by the foot point of their bed normal on cells of dx (2D: x; 3D: x and z). A bin has
// fractured through the slab when its fractured particles, together with those of its two
// neighbours along x (a crack one particle wide straddles bin edges, and a crack normal to the bed
// leans across vertical columns), fill kThroughShare of the height rows (dx thick, normal to the
// bed) that slab particles occupy. A slab fracture is a connected run of such bins that holds no
// bin that was already through at the previous update.
#pragma once

#include <firn/diagnostics.h>

#include <cstddef>
#include <limits>
#include <vector>

namespace firn {

/// Share of the slab's occupied height rows that fractured particles must fill for a fracture
/// through the slab.
constexpr double kThroughShare = 0.8;

/// A slab particle as the detector sees it.
struct SlabSample {
    Vec3f position = Vec3f::Zero(); ///< world position, m (blocks are cells of it)
    float bedX = 0.f;               ///< foot point of the bed normal: x, m
    float bedZ = 0.f;               ///< and z (2D: 0), m
    float height = 0.f;             ///< above the bed, along its normal, m
    float mass = 0.f;               ///< kg (2D: per metre)
    bool fractured = false;
    float fractureTime = 0.f; ///< s, when it fractured
};

/// The slab particles of a world (Material::slab), in particle order. The bed is the
/// collider nearest to each particle (height: its signed distance, foot: the particle moved
/// back along the collider's normal); without colliders, height is y and the foot x (and z).
std::vector<SlabSample> slabSamples(const World& world);

/// A bin that has fractured through the slab (see the file comment).
struct ThroughBin {
    int ix = 0, iz = 0; ///< bin index along the bed: centre ((ix + 1/2) dx, (iz + 1/2) dx)
    /// s: fracture time of the particle whose fracture filled the kThroughShare-th row.
    double time = 0.0;
    /// Where the first fractured particle of the bin sits in the slab's thickness there:
    /// 0 at the bottom (the weak-layer interface), 1 at the top surface.
    double startDepthFraction = 0.0;
    double startY = 0.0;    ///< world y of that particle, m
    double startTime = 0.0; ///< s: when that particle fractured, the fracture's start
};

/// The bins fractured through the slab, ordered by (iz, ix). Deterministic: the result does not
/// depend on the order of the samples.
std::vector<ThroughBin> findThroughBins(const std::vector<SlabSample>& samples, double dx, int dim);

/// Slab blocks: face-connected components of the grid cells (dx) that hold intact (never
/// fractured) slab particles; mass is that of their intact particles.
struct SlabBlocks {
    std::size_t count = 0;
    double largestMass = std::numeric_limits<double>::quiet_NaN(); ///< kg (2D: per metre)
    double medianMass = std::numeric_limits<double>::quiet_NaN();  ///< kg (2D: per metre)
};
SlabBlocks findSlabBlocks(const std::vector<SlabSample>& samples, double dx, int dim);

/// One slab fracture, recorded where and when it first went through the slab.
struct SlabFracture {
    double x = 0.0, y = 0.0, z = 0.0; ///< m: bin centre along the bed (x, z), start y
    double time = 0.0;                ///< s, ThroughBin::time of that bin
    double startDepthFraction = 0.0;  ///< ThroughBin::startDepthFraction
    /// m: weak-layer crack tip at `time` minus x, along the tip's direction of travel (> 0:
    /// behind the tip); NaN while there is no crack.
    double distanceBehindCrackTip = std::numeric_limits<double>::quiet_NaN();
    double startTime = 0.0; ///< s, ThroughBin::startTime of that bin (<= time)
    /// m: the same distance at `startTime`, where the slab crack began (Gaume et al. 2019 give
    /// one distance, "< 1 m", without saying at which moment: both are recorded).
    double distanceBehindCrackTipAtStart = std::numeric_limits<double>::quiet_NaN();
};

/// Records slab fractures as they go through, and the slab's blocks, once per output frame.
class SlabFractureTracker {
public:
    /// The frame at `time`: a connected run of through bins none of which went through at or
    /// before the previous update's time is a new fracture, placed at its earliest bin (ties:
    /// lowest iz, then ix). `crack` must already hold this frame.
    void update(const std::vector<SlabSample>& samples, double dx, int dim, double time,
                const CrackTracker& crack);
    /// Every fracture so far, in the order they went through.
    const std::vector<SlabFracture>& fractures() const { return mFractures; }
    const SlabBlocks& blocks() const { return mBlocks; } ///< of the last update
    std::size_t maxBlocks() const { return mMaxBlocks; }
    /// Fractured share of the slab mass at the last update; NaN without slab.
    double fracturedMassFraction() const { return mFracturedFraction; }

    /// The whole state, for checkpoints: load(save()) continues exactly where save left off.
    void save(ByteWriter& out) const;
    void load(ByteReader& in);

private:
    double mPreviousTime = -std::numeric_limits<double>::infinity();
    std::vector<SlabFracture> mFractures;
    SlabBlocks mBlocks;
    std::size_t mMaxBlocks = 0;
    double mFracturedFraction = std::numeric_limits<double>::quiet_NaN();
};

} // namespace firn
