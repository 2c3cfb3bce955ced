#include "report/deposit_profile.h"

#include <cmath>
#include <map>
#include <set>

namespace firn::report {

std::vector<DepthCell> snowDepthAlongX(const ParticleFrame& frame, double dx, int dimension,
                                       int particlesPerCell) {
    struct Column {
        std::size_t particles = 0;
        std::set<long> zCells; // 3D: the z cells of dx holding snow at this x
    };
    std::map<long, Column> columns; // by x cell: sorted, whatever the particle order
    for (const auto& P : frame.P) {
        Column& c = columns[long(std::floor(P[0] / dx))];
        ++c.particles;
        if (dimension == 3) c.zCells.insert(long(std::floor(P[2] / dx)));
    }
    const double particleVolume = std::pow(dx, dimension) / particlesPerCell;
    std::vector<DepthCell> cells;
    cells.reserve(columns.size());
    for (const auto& [ix, c] : columns) {
        const double width = dimension == 3 ? double(c.zCells.size()) * dx : 1.0;
        cells.push_back(
            {(double(ix) + 0.5) * dx, double(c.particles) * particleVolume / (dx * width)});
    }
    return cells;
}

} // namespace firn::report
