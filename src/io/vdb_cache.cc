// Particle and volume caches (outputs.md). Both live in this one translation unit because
// OpenVDB's point conversion and I/O headers cost about half a minute of compile time each
// time they are included.
#include <firn/io.h>

#include "vdb_file.h"

#include <openvdb/io/Archive.h>
#include <openvdb/openvdb.h>
#include <openvdb/points/PointConversion.h>
#include <openvdb/points/PointDataGrid.h>
#include <openvdb/tools/PointIndexGrid.h>

#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace firn {
namespace {

using openvdb::Index;
using openvdb::points::PointDataGrid;
using openvdb::points::PointDataTree;
using openvdb::tools::PointIndexGrid;
using openvdb::tools::PointIndexTree;

constexpr Index kLeafVoxels = openvdb::FloatTree::LeafNodeType::SIZE; // 512

openvdb::Vec3f toVdb(const std::array<float, 3>& a) {
    return {a[0], a[1], a[2]};
}
float toVdb(float x) {
    return x;
}
std::int32_t toVdb(std::int32_t x) {
    return x;
}

/// One ParticleFrame array seen through OpenVDB's point-array interface (that of
/// points::PointAttributeVector): positions for the PointPartitioner, values for
/// populateAttribute. A view, so a frame is never copied.
template <typename SourceT> class ArrayView {
public:
    using value_type = decltype(toVdb(std::declval<SourceT>()));
    using PosType = value_type;

    explicit ArrayView(const std::vector<SourceT>& data)
        : mData(data) {}
    size_t size() const { return mData.size(); }
    void getPos(size_t n, PosType& xyz) const { xyz = toVdb(mData[n]); }
    void get(value_type& value, size_t n, Index = 0) const { value = toVdb(mData[n]); }

private:
    const std::vector<SourceT>& mData;
};

IoError ioError(const std::string& path, const std::string& reason) {
    return IoError("cannot write " + path + ": " + reason);
}

void checkVoxelSize(double voxelSize) {
    if (!(std::isfinite(voxelSize) && voxelSize > 0.0)) {
        throw std::invalid_argument("cache voxel size must be positive and finite, got " +
                                    std::to_string(voxelSize));
    }
}

template <typename T>
void checkLength(const std::vector<T>& values, size_t expected, const char* name) {
    if (values.size() != expected) {
        throw std::invalid_argument(std::string("cache array '") + name + "' has " +
                                    std::to_string(values.size()) + " entries, expected " +
                                    std::to_string(expected));
    }
}

void checkParticles(const ParticleFrame& particles) {
    const size_t n = particles.P.size();
    checkLength(particles.v, n, "v");
    checkLength(particles.material, n, "material");
    checkLength(particles.failed, n, "failed");
    checkLength(particles.eps_v, n, "eps_v");
    checkLength(particles.eta, n, "eta");
    checkLength(particles.p, n, "p");
    checkLength(particles.q, n, "q");
    // A NaN position has no voxel: the point partitioner would convert it to an integer.
    for (size_t i = 0; i < n; ++i) {
        const auto& x = particles.P[i];
        if (!(std::isfinite(x[0]) && std::isfinite(x[1]) && std::isfinite(x[2]))) {
            throw std::invalid_argument("particle " + std::to_string(i) +
                                        " has a non-finite position");
        }
    }
}

////////////////////////////////////////

// Particle cache

/// Appends a NullCodec attribute and fills it in the order of `index`, the point index grid
/// the point data grid was built from.
template <typename SourceT>
void addAttribute(PointDataTree& tree, const PointIndexTree& index, const std::string& name,
                  const std::vector<SourceT>& values) {
    using ValueT = typename ArrayView<SourceT>::value_type;
    openvdb::points::appendAttribute<ValueT>(tree, name);
    openvdb::points::populateAttribute(tree, index, name, ArrayView<SourceT>(values));
}

/// Frees a frame's array once the grid holds it.
template <typename T> void release(std::vector<T>& values) {
    std::vector<T>().swap(values);
}

/// The point grid of a frame, emptying the frame array by array as the grid takes each in: a
/// frame's arrays and the grid's attributes (about 50 bytes a particle each) are then never all
/// held at once, and a frame write adds less to the run's peak memory.
PointDataGrid::Ptr makePointGrid(ParticleFrame& particles, double voxelSize) {
    using namespace openvdb;
    const auto xform = math::Transform::createLinearTransform(voxelSize);
    const ArrayView<std::array<float, 3>> positions(particles.P);
    const auto index = tools::createPointIndexGrid<PointIndexGrid>(positions, *xform);
    // NullCodec: full float offsets from the voxel centre, not quantised ones (style.md). Read
    // back, a coordinate 1.5 voxels or more from the origin is bit-exact; nearer, the offset is
    // no finer than the coordinate itself and it may come back one float step away.
    auto grid =
        points::createPointDataGrid<points::NullCodec, PointDataGrid>(*index, positions, *xform);
    release(particles.P); // the grid holds the positions now; the index, their order
    auto& tree = grid->tree();
    const auto add = [&](const std::string& name, auto& values) {
        addAttribute(tree, index->tree(), name, values);
        release(values);
    };
    add("v", particles.v);
    add("material", particles.material);
    add("failed", particles.failed);
    add("eps_v", particles.eps_v);
    add("eta", particles.eta);
    add("p", particles.p);
    add("q", particles.q);
    grid->setName("points");
    return grid;
}

////////////////////////////////////////

// Volume cache

struct VolumeGrids {
    openvdb::FloatGrid::Ptr density;
    openvdb::Vec3fGrid::Ptr velocity;
    openvdb::FloatGrid::Ptr failed;
    openvdb::FloatGrid::Ptr eta;
};

VolumeGrids makeEmptyVolumeGrids(const std::vector<std::string>& names, double voxelSize) {
    VolumeGrids out;
    for (const std::string& name : names) {
        if (name == "density") {
            out.density = openvdb::FloatGrid::create(0.f);
            out.density->setGridClass(openvdb::GRID_FOG_VOLUME);
        } else if (name == "velocity") {
            out.velocity = openvdb::Vec3fGrid::create(openvdb::Vec3f(0.f));
            // A velocity transforms like a displacement: rotated and scaled, never translated.
            out.velocity->setVectorType(openvdb::VEC_CONTRAVARIANT_RELATIVE);
        } else if (name == "failed") {
            out.failed = openvdb::FloatGrid::create(0.f);
        } else if (name == "eta") {
            out.eta = openvdb::FloatGrid::create(0.f);
        } else {
            throw std::invalid_argument("unknown volume grid '" + name +
                                        "' (expected density, velocity, failed or eta)");
        }
    }
    // Node i of the simulation grid sits at i*dx, which is VDB index space times the voxel
    // size: a plain scale, no half-voxel shift.
    const auto xform = openvdb::math::Transform::createLinearTransform(voxelSize);
    if (out.density) out.density->setTransform(xform->copy());
    if (out.velocity) out.velocity->setTransform(xform->copy());
    if (out.failed) out.failed->setTransform(xform->copy());
    if (out.eta) out.eta->setTransform(xform->copy());
    return out;
}

bool hasMass(const VolumeFrame& volume, size_t block) {
    const float* density = volume.density.data() + block * kLeafVoxels;
    for (Index i = 0; i < kLeafVoxels; ++i) {
        if (density[i] > 0.f) return true;
    }
    return false;
}

template <typename GridT>
typename GridT::TreeType::LeafNodeType* touchLeaf(GridT* grid, const openvdb::Coord& origin) {
    return grid ? grid->tree().touchLeaf(origin) : nullptr;
}

/// Copies block `block` into its leaves. The block offsets are LeafNode offsets (io.h), so the
/// values go in without any coordinate arithmetic. Voxels without mass stay inactive at the
/// background 0: a renderer reads their value, and an empty node has no velocity.
void fillBlock(const VolumeFrame& volume, size_t block, VolumeGrids& grids) {
    const auto& o = volume.origin[block];
    const openvdb::Coord origin(o[0], o[1], o[2]);
    auto* density = touchLeaf(grids.density.get(), origin);
    auto* velocity = touchLeaf(grids.velocity.get(), origin);
    auto* failed = touchLeaf(grids.failed.get(), origin);
    auto* eta = touchLeaf(grids.eta.get(), origin);
    const size_t base = block * kLeafVoxels;
    for (Index i = 0; i < kLeafVoxels; ++i) {
        if (!(volume.density[base + i] > 0.f)) continue;
        if (density) density->setValueOn(i, volume.density[base + i]);
        if (velocity) velocity->setValueOn(i, toVdb(volume.velocity[base + i]));
        if (failed) failed->setValueOn(i, volume.failed[base + i]);
        if (eta) eta->setValueOn(i, volume.eta[base + i]);
    }
}

void checkVolume(const VolumeFrame& volume, const VolumeGrids& grids) {
    const size_t values = volume.origin.size() * kLeafVoxels;
    checkLength(volume.density, values, "density"); // needed by every grid: it sets activity
    if (grids.velocity) checkLength(volume.velocity, values, "velocity");
    if (grids.failed) checkLength(volume.failed, values, "failed");
    if (grids.eta) checkLength(volume.eta, values, "eta");
    for (const auto& o : volume.origin) {
        if ((o[0] | o[1] | o[2]) & 7) {
            throw std::invalid_argument("volume block origin (" + std::to_string(o[0]) + ", " +
                                        std::to_string(o[1]) + ", " + std::to_string(o[2]) +
                                        ") is not a multiple of 8");
        }
    }
}

VolumeGrids makeVolumeGrids(const VolumeFrame& volume, const std::vector<std::string>& names) {
    VolumeGrids grids = makeEmptyVolumeGrids(names, volume.voxelSize);
    checkVolume(volume, grids);
    // Blocks without mass are skipped rather than pruned afterwards: no empty leaf is made.
    for (size_t b = 0; b < volume.origin.size(); ++b) {
        if (hasMass(volume, b)) fillBlock(volume, b, grids);
    }
    if (grids.density) grids.density->setName("density");
    if (grids.velocity) grids.velocity->setName("velocity");
    if (grids.failed) grids.failed->setName("failed");
    if (grids.eta) grids.eta->setName("eta");
    return grids;
}

////////////////////////////////////////

// Files

/// Frame metadata, and the local frame's origin added to the grid's transform: the grids are
/// built in the simulation's frame, and read back in the scene's (a DEM's eastings, northings).
void setFrameMetadata(openvdb::GridBase& grid, const FrameInfo& info) {
    const openvdb::Vec3d origin(info.origin[0], info.origin[1], info.origin[2]);
    if (origin != openvdb::Vec3d(0.0)) {
        grid.transform().postTranslate(origin);
        grid.insertMeta("firn_frame_origin", openvdb::Vec3DMetadata(origin));
    }
    grid.insertMeta("time", openvdb::DoubleMetadata(info.time));
    grid.insertMeta("frame", openvdb::Int32Metadata(info.frame));
    grid.insertMeta("frame_rate", openvdb::DoubleMetadata(info.frameRate));
    grid.setCreator("firn");
}

/// Blosc as outputs.md asks; a build of OpenVDB without it would throw on write, so such a
/// build falls back to zlib, which every reader also understands.
uint32_t compressionFlags() {
    const uint32_t codec = openvdb::io::Archive::hasBloscCompression() ? openvdb::io::COMPRESS_BLOSC
                                                                       : openvdb::io::COMPRESS_ZIP;
    return codec | openvdb::io::COMPRESS_ACTIVE_MASK;
}

/// An OpenVDB file's header holds a random UUID (36 characters after the magic number, the
/// file and library versions and the grid-offsets flag): two writes of the same grids differ
/// there and only there. Replacing it with one made from a hash of the rest keeps it unique per
/// content (what readers use it for) and makes the same frame the same bytes, as determinism
/// and resumed runs promise (outputs.md).
void setContentUuid(std::string& file) {
    constexpr std::size_t kUuidOffset = 8 + 4 + 4 + 4 + 1, kUuidLength = 36;
    if (file.size() < kUuidOffset + kUuidLength || file[kUuidOffset + 8] != '-')
        throw std::logic_error("unexpected OpenVDB header layout");
    const std::size_t rest = kUuidOffset + kUuidLength;
    // fnv1a64 with two seeds, in one pass: the two chains of multiplies are independent, so they
    // overlap (two passes were most of a frame write's own time on the main thread).
    std::uint64_t hi = 0xcbf29ce484222325ull, lo = 0x84222325cbf29ce4ull;
    for (std::size_t i = rest; i < file.size(); ++i) {
        const auto byte = static_cast<unsigned char>(file[i]);
        hi = (hi ^ byte) * 0x100000001b3ull;
        lo = (lo ^ byte) * 0x100000001b3ull;
    }
    // RFC 9562 version 8 (vendor-specific) with the RFC variant bits.
    const std::uint64_t hiV8 = (hi & ~0xf000ull) | 0x8000ull;
    lo = (lo & 0x3fffffffffffffffull) | 0x8000000000000000ull;
    char text[kUuidLength + 1];
    std::snprintf(text, sizeof text, "%08llx-%04llx-%04llx-%04llx-%012llx",
                  (unsigned long long)(hiV8 >> 32), (unsigned long long)((hiV8 >> 16) & 0xffff),
                  (unsigned long long)(hiV8 & 0xffff), (unsigned long long)(lo >> 48),
                  (unsigned long long)(lo & 0xffffffffffffull));
    file.replace(kUuidOffset, kUuidLength, text, kUuidLength);
}

/// An archive that writes into a stream of ours (Archive::write is protected).
class MemoryArchive : public openvdb::io::Archive {
public:
    void writeTo(std::ostream& os, const openvdb::GridCPtrVec& grids) const {
        Archive::write(os, grids, /*seekable=*/true);
    }
};

} // namespace

// The archive goes to memory first: io::File opens its own stream and never checks it, so a
// full disk would leave a truncated file that seems fine; writeFileAtomic checks every write.
void writeVdbFileAtomic(const std::string& path, const openvdb::GridCPtrVec& grids) {
    std::ostringstream os(std::ios::out | std::ios::binary);
    try {
        MemoryArchive archive;
        archive.setCompression(compressionFlags());
        archive.writeTo(os, grids);
    } catch (const openvdb::Exception& e) {
        throw ioError(path, e.what());
    }
    std::string bytes = os.str();
    setContentUuid(bytes);
    writeFileAtomic(path, bytes);
}

namespace {

/// Writes `dir/name`, so the frame appears only complete.
void writeGridsAtomic(const std::string& dir, const std::string& name,
                      const openvdb::GridCPtrVec& grids) {
    writeVdbFileAtomic((dir.empty() ? std::string() : dir + "/") + name, grids);
}

} // namespace

void writeParticleCache(const std::string& dir, const FrameInfo& info, double voxelSize,
                        ParticleFrame particles) {
    checkVoxelSize(voxelSize);
    checkParticles(particles);
    openvdb::initialize(); // idempotent, and cheap after the first call
    const PointDataGrid::Ptr grid = makePointGrid(particles, voxelSize);
    setFrameMetadata(*grid, info);
    writeGridsAtomic(dir, frameFileName("particles", info.frame), {grid});
}

void writeVolumeCache(const std::string& dir, const FrameInfo& info, const VolumeFrame& volume,
                      const std::vector<std::string>& grids) {
    checkVoxelSize(volume.voxelSize);
    openvdb::initialize();
    const VolumeGrids built = makeVolumeGrids(volume, grids);
    // outputs.md order, whatever the order of `grids`.
    openvdb::GridPtrVec out;
    if (built.density) out.push_back(built.density);
    if (built.velocity) out.push_back(built.velocity);
    if (built.failed) out.push_back(built.failed);
    if (built.eta) out.push_back(built.eta);
    for (const auto& grid : out) setFrameMetadata(*grid, info);
    writeGridsAtomic(dir, frameFileName("volume", info.frame), {out.begin(), out.end()});
}

} // namespace firn
