// The weak layer seen from above, as in Gaume et al. (2019), Fig. A1: particles binned on cells
// of the grid spacing (along x in 2D, on an x-z raster in 3D; y is up).
#pragma once

#include <firn/io.h>

#include <vector>

namespace firn::report {

/// One cell that holds weak-layer particles.
struct WeakLayerCell {
    double x = 0, z = 0;       ///< cell centre, m (z = 0 in 2D)
    int particles = 0;         ///< weak-layer particles in the cell
    double failedFraction = 0; ///< share of them that have yielded at least once
    double eta = 0;            ///< their mean anticrack strain
    double p = 0;              ///< their mean pressure, Pa
    /// Mean speed of the slab in the same column, m/s: the other particles above the weak
    /// layer's mean height there (not the base below it); NaN when it has none.
    double slabSpeed = 0;
    /// Share of those slab particles that have yielded at least once (Fig. A1's slab map); NaN
    /// when it has none.
    double slabFailedFraction = 0;
    /// Mean pressure p = -tr(tau)/d of those slab particles, Pa: negative where the slab is in
    /// tension (Fig. A1's slab stress map); NaN when it has none.
    double slabP = 0;
    /// Mean share of the initial strength the weak-layer particles' stress uses
    /// (camClayStrengthUsed on their material's initial surface): at t = 0 how close the static
    /// load is to failure (1: on the surface); after softening it still refers to the initial
    /// surface.
    double strengthUsed = 0;
};

/// What the binning needs of each material, by its index in the scene.
struct WeakLayerMaterial {
    bool isWeakLayer = false;
    double p0 = 0, M = 0, beta = 0; ///< a weak layer's initial Cam-Clay surface (eq. 1)
};

/// Bins `frame` on cells of size `dx` (x in 2D, x-z in 3D). materials[m] says whether material
/// index m is a weak layer, and its initial surface; other particles above the weak layer's
/// mean height in the column count as slab. Cells come ordered by z, then
/// x, so the output does not depend on the particle order.
std::vector<WeakLayerCell> binWeakLayer(const ParticleFrame& frame,
                                        const std::vector<WeakLayerMaterial>& materials, double dx,
                                        int dimension);

} // namespace firn::report
