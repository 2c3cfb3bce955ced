#include "report/weak_layer_map.h"

#include <firn/material.h>

#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <utility>

namespace firn::report {
namespace {

struct Sums {
    int weak = 0, failed = 0, slab = 0, slabFailed = 0;
    double eta = 0, p = 0, weakHeight = 0, slabSpeed = 0, slabP = 0, strengthUsed = 0;
};

const WeakLayerMaterial* weakLayerOf(const std::vector<WeakLayerMaterial>& materials,
                                     std::int32_t material) {
    if (material < 0 || std::size_t(material) >= materials.size()) return nullptr;
    return materials[std::size_t(material)].isWeakLayer ? &materials[std::size_t(material)]
                                                        : nullptr;
}

} // namespace

std::vector<WeakLayerCell> binWeakLayer(const ParticleFrame& frame,
                                        const std::vector<WeakLayerMaterial>& materials, double dx,
                                        int dimension) {
    // Keyed (z, x) so that iteration gives raster order. Two passes: the weak layer's mean
    // height per column first, then the slab above it (a base layer below is not slab).
    std::map<std::pair<long, long>, Sums> cells;
    auto cellOf = [&](const std::array<float, 3>& P) {
        const long ix = long(std::floor(P[0] / dx));
        const long iz = dimension == 3 ? long(std::floor(P[2] / dx)) : 0;
        return std::make_pair(iz, ix);
    };
    for (std::size_t i = 0; i < frame.P.size(); ++i) {
        const WeakLayerMaterial* weak = weakLayerOf(materials, frame.material[i]);
        if (!weak) continue;
        Sums& s = cells[cellOf(frame.P[i])];
        ++s.weak;
        s.failed += frame.failed[i] != 0;
        s.eta += frame.eta[i];
        s.p += frame.p[i];
        s.weakHeight += frame.P[i][1];
        s.strengthUsed +=
            camClayStrengthUsed(frame.p[i], frame.q[i], weak->p0, weak->M, weak->beta);
    }
    for (std::size_t i = 0; i < frame.P.size(); ++i) {
        if (weakLayerOf(materials, frame.material[i])) continue;
        const auto cell = cells.find(cellOf(frame.P[i]));
        if (cell == cells.end()) continue;
        Sums& s = cell->second;
        if (!(frame.P[i][1] > s.weakHeight / s.weak)) continue;
        const auto& v = frame.v[i];
        ++s.slab;
        s.slabFailed += frame.failed[i] != 0;
        s.slabSpeed += std::sqrt(double(v[0]) * v[0] + double(v[1]) * v[1] + double(v[2]) * v[2]);
        s.slabP += frame.p[i];
    }
    std::vector<WeakLayerCell> out;
    for (const auto& [key, s] : cells) {
        WeakLayerCell c;
        c.x = (key.second + 0.5) * dx;
        c.z = dimension == 3 ? (key.first + 0.5) * dx : 0.0;
        c.particles = s.weak;
        c.failedFraction = double(s.failed) / s.weak;
        c.eta = s.eta / s.weak;
        c.p = s.p / s.weak;
        c.strengthUsed = s.strengthUsed / s.weak;
        const double none = std::numeric_limits<double>::quiet_NaN();
        c.slabSpeed = s.slab > 0 ? s.slabSpeed / s.slab : none;
        c.slabFailedFraction = s.slab > 0 ? double(s.slabFailed) / s.slab : none;
        c.slabP = s.slab > 0 ? s.slabP / s.slab : none;
        out.push_back(c);
    }
    return out;
}

} // namespace firn::report
