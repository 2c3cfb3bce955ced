// The yardstick of issue 2/4: OpenVDB's own points::rasterizeTrilinear on the same particles as
// our P2G, timed in the same run. Kept in its own translation unit: it is the only part of the
// benchmark that includes OpenVDB's point headers.
#include "compare_openvdb.h"

#include <firn/transfer.h>

#include <openvdb/openvdb.h>
#include <openvdb/points/PointConversion.h>
#include <openvdb/points/PointRasterizeTrilinear.h>
#include <openvdb/tools/PointIndexGrid.h>

#include <chrono>

namespace firn::bench {

namespace {
double seconds(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
} // namespace

RasterComparison compareWithOpenvdb(const ParticleSet& ps, int repetitions) {
    openvdb::initialize();
    std::vector<openvdb::Vec3f> positions(ps.size()), velocities(ps.size());
    for (std::size_t i = 0; i < ps.size(); ++i) {
        positions[i] = openvdb::Vec3f(ps.x[i][0], ps.x[i][1], ps.x[i][2]);
        velocities[i] = openvdb::Vec3f(ps.v[i][0], ps.v[i][1], ps.v[i][2]);
    }
    const openvdb::points::PointAttributeVector<openvdb::Vec3f> pointList(positions);
    const auto transform = openvdb::math::Transform::createLinearTransform(ps.dx);
    const auto indexGrid =
        openvdb::tools::createPointIndexGrid<openvdb::tools::PointIndexGrid>(pointList, *transform);
    auto points = openvdb::points::createPointDataGrid<openvdb::points::NullCodec,
                                                       openvdb::points::PointDataGrid>(
        *indexGrid, pointList, *transform);
    openvdb::points::appendAttribute<openvdb::Vec3f>(points->tree(), "v");
    const openvdb::points::PointAttributeVector<openvdb::Vec3f> velocityList(velocities);
    openvdb::points::populateAttribute(points->tree(), indexGrid->tree(), "v", velocityList);

    RasterComparison result;
    result.particles = ps.size();
    auto t0 = std::chrono::steady_clock::now();
    for (int r = 0; r < repetitions; ++r) {
        auto tree = openvdb::points::rasterizeTrilinear<false, openvdb::Vec3f>(points->tree(), "v");
        result.openvdbVoxels = tree->activeVoxelCount();
    }
    result.openvdbSeconds = seconds(t0) / repetitions;

    Grid grid;
    TransferScratch scratch;
    const TransferParams params{ps.dim, ps.dx, 1e-4f, Transfer::Apic, 0.f};
    t0 = std::chrono::steady_clock::now();
    for (int r = 0; r < repetitions; ++r) {
        grid.rebuild(ps, 0);
        particlesToGrid(ps, grid, params, scratch);
    }
    result.firnSeconds = seconds(t0) / repetitions;
    return result;
}

} // namespace firn::bench
