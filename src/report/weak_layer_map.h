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
};

/// Bins `frame` on cells of size `dx` (x in 2D, x-z in 3D). isWeakLayer[m] says whether
/// material index m is a weak layer; other particles above the weak layer's mean height in
/// the column count as slab. Cells come ordered by z, then
/// x, so the output does not depend on the particle order.
std::vector<WeakLayerCell> binWeakLayer(const ParticleFrame& frame,
                                        const std::vector<bool>& isWeakLayer, double dx,
                                        int dimension);

} // namespace firn::report
