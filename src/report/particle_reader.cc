#include "report/particle_reader.h"

#include <openvdb/openvdb.h>
#include <openvdb/points/PointAttribute.h>
#include <openvdb/points/PointDataGrid.h>

#include <algorithm>
#include <filesystem>
#include <regex>

namespace firn::report {
namespace {

using openvdb::points::AttributeHandle;
using openvdb::points::PointDataGrid;

IoError readError(const std::string& path, const std::string& reason) {
    return IoError("cannot read " + path + ": " + reason);
}

std::array<float, 3> fromVdb(const openvdb::Vec3f& v) {
    return {v.x(), v.y(), v.z()};
}
float fromVdb(float x) {
    return x;
}
std::int32_t fromVdb(std::int32_t x) {
    return x;
}

/// Appends the values of attribute `name` of one leaf, in the leaf's point order (the order
/// in which positions are appended, so the arrays stay aligned).
template <typename ValueT, typename OutT>
void appendAttribute(const PointDataGrid::TreeType::LeafNodeType& leaf, const std::string& name,
                     const std::string& path, std::vector<OutT>& out) {
    if (leaf.attributeSet().find(name) == openvdb::points::AttributeSet::INVALID_POS) {
        throw readError(path, "the point grid has no attribute '" + name + "'");
    }
    const AttributeHandle<ValueT> handle(leaf.constAttributeArray(name));
    for (auto index = leaf.beginIndexOn(); index; ++index)
        out.push_back(fromVdb(handle.get(*index)));
}

void appendPositions(const PointDataGrid& grid, const PointDataGrid::TreeType::LeafNodeType& leaf,
                     const std::string& path, std::vector<std::array<float, 3>>& out) {
    if (leaf.attributeSet().find("P") == openvdb::points::AttributeSet::INVALID_POS) {
        throw readError(path, "the point grid has no attribute 'P'");
    }
    // P holds the offset from the voxel centre, in voxels.
    const AttributeHandle<openvdb::Vec3f> offset(leaf.constAttributeArray("P"));
    for (auto index = leaf.beginIndexOn(); index; ++index) {
        const openvdb::Vec3d voxel = index.getCoord().asVec3d() + offset.get(*index);
        out.push_back(fromVdb(openvdb::Vec3f(grid.transform().indexToWorld(voxel))));
    }
}

template <typename T> T metaOr(const openvdb::GridBase& grid, const char* name, T fallback) {
    const auto meta = grid.getMetadata<openvdb::TypedMetadata<T>>(name);
    return meta ? meta->value() : fallback;
}

} // namespace

CachedFrame readParticleFrame(const std::string& path) {
    openvdb::initialize();
    openvdb::GridBase::Ptr base;
    try {
        openvdb::io::File file(path);
        file.open();
        if (!file.hasGrid("points")) throw readError(path, "no grid named 'points'");
        base = file.readGrid("points");
        file.close();
    } catch (const openvdb::Exception& e) {
        throw readError(path, e.what());
    }
    const auto grid = openvdb::gridPtrCast<PointDataGrid>(base);
    if (!grid) throw readError(path, "grid 'points' is not a point data grid");

    CachedFrame frame;
    frame.info.time = metaOr<double>(*grid, "time", 0.0);
    frame.info.frame = metaOr<std::int32_t>(*grid, "frame", 0);
    frame.info.frameRate = metaOr<double>(*grid, "frame_rate", 0.0);
    ParticleFrame& out = frame.particles;
    for (auto leaf = grid->tree().cbeginLeaf(); leaf; ++leaf) {
        appendPositions(*grid, *leaf, path, out.P);
        appendAttribute<openvdb::Vec3f>(*leaf, "v", path, out.v);
        appendAttribute<std::int32_t>(*leaf, "material", path, out.material);
        appendAttribute<std::int32_t>(*leaf, "failed", path, out.failed);
        appendAttribute<float>(*leaf, "eps_v", path, out.eps_v);
        appendAttribute<float>(*leaf, "eta", path, out.eta);
        appendAttribute<float>(*leaf, "p", path, out.p);
        appendAttribute<float>(*leaf, "q", path, out.q);
    }
    return frame;
}

std::vector<int> listParticleFrames(const std::string& framesDir) {
    std::vector<int> frames;
    std::error_code error;
    if (!std::filesystem::is_directory(framesDir, error)) return frames;
    const std::regex name(R"(particles\.(\d{4,})\.vdb)");
    for (const auto& entry : std::filesystem::directory_iterator(framesDir, error)) {
        std::smatch m;
        const std::string file = entry.path().filename().string();
        if (std::regex_match(file, m, name)) frames.push_back(std::stoi(m[1]));
    }
    if (error) throw readError(framesDir, error.message());
    std::sort(frames.begin(), frames.end());
    return frames;
}

} // namespace firn::report
