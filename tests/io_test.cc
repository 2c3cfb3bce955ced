// Caches and reports (outputs.md): what a renderer or a script reads back is what was written.
#include <firn/io.h>

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/points/PointCount.h>
#include <openvdb/points/PointDataGrid.h>

#include <catch2/catch.hpp>

#include <sys/resource.h>
#include <unistd.h>

#include <array>
#include <cfloat>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <random>
#include <sstream>

namespace fs = std::filesystem;
using namespace firn;

namespace {

/// A fresh folder under the system temp folder, removed with its contents at scope exit.
class TempDir {
public:
    TempDir() {
        static int counter = 0;
        const std::string name = "firn_io_test_" + std::to_string(::getpid()) + "_" +
                                 std::to_string(counter++) + "_" +
                                 std::to_string(std::random_device{}());
        mPath = fs::temp_directory_path() / name;
        fs::create_directories(mPath);
    }
    ~TempDir() {
        std::error_code ec;
        fs::remove_all(mPath, ec);
    }
    std::string str() const { return mPath.string(); }
    std::string file(const std::string& name) const { return (mPath / name).string(); }

private:
    fs::path mPath;
};

std::string readText(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

std::vector<std::string> fileNames(const std::string& dir) {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir)) {
        names.push_back(entry.path().filename().string());
    }
    return names;
}

bool hasTempFile(const std::string& dir) {
    for (const auto& name : fileNames(dir)) {
        if (name.size() >= 4 && name.compare(name.size() - 4, 4, ".tmp") == 0) return true;
    }
    return false;
}

openvdb::GridPtrVecPtr readGrids(const std::string& path) {
    openvdb::initialize();
    openvdb::io::File file(path);
    file.open();
    openvdb::GridPtrVecPtr grids = file.getGrids();
    file.close();
    return grids;
}

/// The compression the writer recorded on the grid ("blosc + active values").
std::string fileCompression(const openvdb::GridBase& grid) {
    return grid.metaValue<std::string>(openvdb::GridBase::META_FILE_COMPRESSION);
}

void checkFrameMetadata(const openvdb::GridBase& grid, const FrameInfo& info) {
    CHECK(grid.metaValue<double>("time") == info.time);
    CHECK(grid.metaValue<int32_t>("frame") == info.frame);
    CHECK(grid.metaValue<double>("frame_rate") == info.frameRate);
}

////////////////////////////////////////

// Particles

ParticleFrame makeParticles(size_t n, float extent, unsigned seed, bool planar = false) {
    std::mt19937 rng(seed);
    // Drawn in double and rounded: every float in range can come up, as in a simulation.
    std::uniform_real_distribution<double> uniform(-extent, extent);
    auto position = [&] { return float(uniform(rng)); };
    std::uniform_real_distribution<float> velocity(-3.f, 3.f);
    ParticleFrame out;
    for (size_t i = 0; i < n; ++i) {
        out.P.push_back({position(), position(), planar ? 0.f : position()});
        out.v.push_back({velocity(rng), velocity(rng), velocity(rng)});
        out.material.push_back(std::int32_t(i % 3));
        out.failed.push_back(std::int32_t(i % 7 == 0));
        out.eps_v.push_back(-1e-3f * float(i));
        out.eta.push_back(i % 5 == 0 ? 0.25f * float(i) : 0.f);
        out.p.push_back(1000.f + float(i));
        out.q.push_back(float(i) * 0.5f);
    }
    return out;
}

/// One point as a reader sees it: positions from voxel coordinates and offsets, as
/// points::convertPointDataGridPosition and renderers compute them.
struct ReadPoint {
    std::array<float, 3> P, v;
    std::int32_t material, failed;
    float eps_v, eta, p, q;
};

template <typename T>
openvdb::points::AttributeHandle<T>
handleOf(const openvdb::points::PointDataTree::LeafNodeType& leaf, const std::string& name) {
    return openvdb::points::AttributeHandle<T>(leaf.constAttributeArray(name));
}

std::vector<ReadPoint> readPoints(const openvdb::points::PointDataGrid& grid) {
    using openvdb::Vec3f;
    std::vector<ReadPoint> out;
    for (auto leaf = grid.tree().cbeginLeaf(); leaf; ++leaf) {
        auto P = handleOf<Vec3f>(*leaf, "P"), v = handleOf<Vec3f>(*leaf, "v");
        auto material = handleOf<std::int32_t>(*leaf, "material");
        auto failed = handleOf<std::int32_t>(*leaf, "failed");
        auto eps_v = handleOf<float>(*leaf, "eps_v"), eta = handleOf<float>(*leaf, "eta");
        auto p = handleOf<float>(*leaf, "p"), q = handleOf<float>(*leaf, "q");
        for (auto i = leaf->beginIndexOn(); i; ++i) {
            const openvdb::Vec3d world =
                grid.transform().indexToWorld(i.getCoord().asVec3d() + P.get(*i));
            const Vec3f vi = v.get(*i);
            out.push_back({{float(world[0]), float(world[1]), float(world[2])},
                           {vi[0], vi[1], vi[2]},
                           material.get(*i),
                           failed.get(*i),
                           eps_v.get(*i),
                           eta.get(*i),
                           p.get(*i),
                           q.get(*i)});
        }
    }
    return out;
}

template <typename ValueT>
void checkAttributeType(const openvdb::points::AttributeSet::Descriptor& descriptor,
                        const std::string& name) {
    INFO("attribute " << name);
    const size_t index = descriptor.find(name);
    REQUIRE(index != openvdb::points::AttributeSet::INVALID_POS);
    CHECK(descriptor.type(index) == openvdb::points::TypedAttributeArray<ValueT>::attributeType());
}

/// The input particle `read` came from: positions may be one float step off (see
/// checkRoundTrip), so its neighbours one step away on each axis are candidates too.
template <typename MapT>
typename MapT::iterator findSource(MapT& byPosition, const std::array<float, 3>& read) {
    const float inf = std::numeric_limits<float>::infinity();
    for (int k = 0; k < 27; ++k) {
        std::array<float, 3> candidate = read;
        for (int a = 0, code = k; a < 3; ++a, code /= 3) {
            if (code % 3 == 1) candidate[a] = std::nextafter(read[a], inf);
            if (code % 3 == 2) candidate[a] = std::nextafter(read[a], -inf);
        }
        const auto found = byPosition.find(candidate);
        if (found != byPosition.end()) return found;
    }
    return byPosition.end();
}

/// Every point comes back once, its attributes bit for bit. A VDB point stores P as a float
/// offset from its voxel centre, which holds a position exactly once it is 1.5 voxels or more
/// from the origin on that axis (the offset is then finer than the position's own float
/// step); nearer, the offset is as coarse as the position and P can come back one float step
/// away.
void checkRoundTrip(const ParticleFrame& in, const std::vector<ReadPoint>& out, double dx) {
    REQUIRE(out.size() == in.P.size());
    std::map<std::array<float, 3>, size_t> byPosition;
    for (size_t i = 0; i < in.P.size(); ++i) byPosition[in.P[i]] = i;
    REQUIRE(byPosition.size() == in.P.size()); // the test needs distinct positions
    size_t matched = 0;
    for (const ReadPoint& point : out) {
        const auto found = findSource(byPosition, point.P);
        if (found == byPosition.end()) {
            FAIL_CHECK("no input particle near (" << point.P[0] << ", " << point.P[1] << ", "
                                                  << point.P[2] << ")");
            continue;
        }
        const size_t i = found->second;
        byPosition.erase(found);
        ++matched;
        for (int a = 0; a < 3; ++a) {
            if (std::abs(in.P[i][a]) >= 1.5 * dx) CHECK(point.P[a] == in.P[i][a]);
        }
        CHECK(point.v == in.v[i]);
        CHECK(point.material == in.material[i]);
        CHECK(point.failed == in.failed[i]);
        CHECK(point.eps_v == in.eps_v[i]);
        CHECK(point.eta == in.eta[i]);
        CHECK(point.p == in.p[i]);
        CHECK(point.q == in.q[i]);
    }
    CHECK(matched == in.P.size());
}

openvdb::points::PointDataGrid::Ptr readPointGrid(const std::string& path) {
    const auto grids = readGrids(path);
    REQUIRE(grids->size() == 1);
    CHECK(grids->front()->getName() == "points");
    auto grid = openvdb::GridBase::grid<openvdb::points::PointDataGrid>(grids->front());
    REQUIRE(grid);
    return grid;
}

/// The output of `vdb_print -l` (Debian's libopenvdb-tools), or nothing when it is missing.
std::string vdbPrint(const std::string& path) {
    const char* binary = "/usr/bin/vdb_print";
    if (!fs::exists(binary)) return {};
    std::string text;
    if (std::FILE* pipe = ::popen((std::string(binary) + " -l '" + path + "' 2>&1").c_str(), "r")) {
        char buffer[4096];
        while (size_t n = std::fread(buffer, 1, sizeof buffer, pipe)) text.append(buffer, n);
        ::pclose(pipe);
    }
    return text;
}

} // namespace

TEST_CASE("particle cache round-trips every attribute", "[io]") {
    TempDir dir;
    const FrameInfo info{7, 0.291666, 24.0};
    double voxelSize = 0.05;
    ParticleFrame in = makeParticles(400, 2.0f, 1);
    SECTION("3D") {}
    SECTION("2D, near the origin") {
        voxelSize = 0.2;
        in = makeParticles(300, 0.5f, 2, /*planar=*/true);
        in.P[0] = {1e-9f, -3e-12f, 0.f};
        in.P[1] = {0.1f, -0.3f, 0.f}; // on voxel faces
        in.P[2] = {-0.f, 0.f, 0.f};
    }
    writeParticleCache(dir.str(), info, voxelSize, in);

    const std::string path = dir.file("particles.0007.vdb");
    REQUIRE(fs::exists(path));
    CHECK_FALSE(hasTempFile(dir.str()));
    const auto grid = readPointGrid(path);
    CHECK(openvdb::points::pointCount(grid->tree()) == in.P.size());
    CHECK(grid->voxelSize()[0] == Approx(voxelSize).epsilon(1e-12));
    checkFrameMetadata(*grid, info);

    const auto leaf = grid->tree().cbeginLeaf();
    REQUIRE(leaf);
    const auto& descriptor = leaf->attributeSet().descriptor();
    CHECK(descriptor.size() == 8);
    checkAttributeType<openvdb::Vec3f>(descriptor, "P");
    checkAttributeType<openvdb::Vec3f>(descriptor, "v");
    checkAttributeType<std::int32_t>(descriptor, "material");
    checkAttributeType<std::int32_t>(descriptor, "failed");
    for (const char* name : {"eps_v", "eta", "p", "q"}) checkAttributeType<float>(descriptor, name);

    checkRoundTrip(in, readPoints(*grid), voxelSize);
    CHECK_THAT(fileCompression(*grid), Catch::Contains("blosc"));
}

TEST_CASE("particle cache of no particles is an empty points grid", "[io]") {
    TempDir dir;
    writeParticleCache(dir.str(), {0, 0.0, 30.0}, 0.1, ParticleFrame{});
    const auto grid = readPointGrid(dir.file("particles.0000.vdb"));
    CHECK(grid->tree().leafCount() == 0);
    CHECK(openvdb::points::pointCount(grid->tree()) == 0);
    checkFrameMetadata(*grid, {0, 0.0, 30.0});
}

TEST_CASE("particle cache failures are IoErrors naming the file", "[io]") {
    TempDir dir;
    const std::string missing = dir.file("no_such_folder");
    const ParticleFrame particles = makeParticles(10, 1.f, 3);
    CHECK_THROWS_AS(writeParticleCache(missing, {3, 0.1, 24.0}, 0.05, particles), IoError);
    CHECK_THROWS_WITH(writeParticleCache(missing, {3, 0.1, 24.0}, 0.05, particles),
                      Catch::Contains(missing + "/particles.0003.vdb") &&
                          Catch::Contains("No such file or directory"));

    ParticleFrame ragged = particles;
    ragged.q.pop_back();
    CHECK_THROWS_AS(writeParticleCache(dir.str(), {}, 0.05, ragged), std::invalid_argument);
    ParticleFrame nan = particles;
    nan.P[4][1] = std::numeric_limits<float>::quiet_NaN();
    CHECK_THROWS_AS(writeParticleCache(dir.str(), {}, 0.05, nan), std::invalid_argument);
    CHECK(fileNames(dir.str()).size() == 0);
}

TEST_CASE("a frame file replaces the previous one whole", "[io]") {
    TempDir dir;
    writeParticleCache(dir.str(), {2, 0.0, 24.0}, 0.05, makeParticles(50, 1.f, 4));
    writeParticleCache(dir.str(), {2, 0.5, 24.0}, 0.05, makeParticles(80, 1.f, 5));
    const auto grid = readPointGrid(dir.file("particles.0002.vdb"));
    CHECK(openvdb::points::pointCount(grid->tree()) == 80);
    CHECK(grid->metaValue<double>("time") == 0.5);
    CHECK(fileNames(dir.str()) == std::vector<std::string>{"particles.0002.vdb"});
}

namespace {

/// Caps the size of the files this process writes, for its scope: past the cap a write fails
/// with EFBIG, which is how a full disk looks from inside a program.
class FileSizeLimit {
public:
    explicit FileSizeLimit(rlim_t bytes) {
        ::getrlimit(RLIMIT_FSIZE, &mSaved);
        mHandler = std::signal(SIGXFSZ, SIG_IGN); // fail the write rather than end the process
        rlimit limit = mSaved;
        limit.rlim_cur = bytes;
        ::setrlimit(RLIMIT_FSIZE, &limit);
    }
    ~FileSizeLimit() {
        ::setrlimit(RLIMIT_FSIZE, &mSaved);
        std::signal(SIGXFSZ, mHandler);
    }

private:
    rlimit mSaved{};
    void (*mHandler)(int) = SIG_DFL;
};

} // namespace

TEST_CASE("a write cut short, as on a full disk, is an IoError and leaves nothing", "[io]") {
    TempDir dir;
    const ParticleFrame particles = makeParticles(100000, 5.f, 7); // about 3 MB on disk
    {
        FileSizeLimit limit(1 << 20);
        CHECK_THROWS_WITH(writeParticleCache(dir.str(), {5, 0.2, 24.0}, 0.05, particles),
                          Catch::Contains(dir.file("particles.0005.vdb")) &&
                              Catch::Contains("File too large"));
        CHECK_THROWS_WITH(writeFileAtomic(dir.file("summary.json"), std::string(2 << 20, 'x')),
                          Catch::Contains(dir.file("summary.json")) &&
                              Catch::Contains("File too large"));
    }
    CHECK(fileNames(dir.str()).empty());
}

////////////////////////////////////////

// Volumes

namespace {

/// Sets one voxel of block `block`, at voxel coordinates `ijk` inside it (io.h layout).
void setVoxel(VolumeFrame& volume, size_t block, const openvdb::Coord& ijk, float density,
              std::array<float, 3> velocity, float failed) {
    const auto& o = volume.origin[block];
    const openvdb::Coord local = ijk - openvdb::Coord(o[0], o[1], o[2]);
    REQUIRE((local.x() >= 0 && local.y() >= 0 && local.z() >= 0));
    REQUIRE((local.x() < 8 && local.y() < 8 && local.z() < 8));
    const size_t index = block * 512 + size_t(local.x() << 6 | local.y() << 3 | local.z());
    volume.density[index] = density;
    volume.velocity[index] = velocity;
    volume.failed[index] = failed;
}

VolumeFrame makeVolume(std::vector<std::array<int, 3>> origins, double voxelSize) {
    VolumeFrame volume;
    volume.voxelSize = voxelSize;
    volume.origin = std::move(origins);
    volume.density.assign(volume.origin.size() * 512, 0.f);
    volume.velocity.assign(volume.origin.size() * 512, {0.f, 0.f, 0.f});
    volume.failed.assign(volume.origin.size() * 512, 0.f);
    return volume;
}

size_t massiveVoxels(const VolumeFrame& volume) {
    size_t n = 0;
    for (float d : volume.density) n += d > 0.f;
    return n;
}

template <typename GridT>
typename GridT::Ptr gridNamed(const openvdb::GridPtrVec& grids, const std::string& name) {
    for (const auto& grid : grids) {
        if (grid->getName() == name) return openvdb::GridBase::grid<GridT>(grid);
    }
    return nullptr;
}

/// The value a reader finds at world position ijk * dx: that is where node ijk sits.
template <typename GridT>
typename GridT::ValueType valueAtNode(const GridT& grid, const openvdb::Coord& ijk, double dx) {
    const openvdb::Vec3d world = ijk.asVec3d() * dx;
    CHECK(grid.transform().worldToIndexCellCentered(world) == ijk);
    return grid.tree().getValue(grid.transform().worldToIndexCellCentered(world));
}

} // namespace

TEST_CASE("volume cache in 3D: sparse leaves, values at nodes, metadata", "[io]") {
    TempDir dir;
    const double dx = 0.1;
    const FrameInfo info{12, 0.5, 24.0};
    // The third block has no mass and must not appear.
    VolumeFrame volume = makeVolume({{0, 0, 0}, {8, -16, 0}, {16, 16, 16}}, dx);
    setVoxel(volume, 0, {0, 0, 0}, 300.f, {1.f, 2.f, 3.f}, 0.f);
    setVoxel(volume, 0, {7, 1, 5}, 250.5f, {-1.f, 0.f, 0.5f}, 1.f);
    setVoxel(volume, 1, {9, -9, 3}, 120.f, {0.f, -4.f, 0.f}, 0.25f);
    setVoxel(volume, 1, {15, -16, 7}, 1e-3f, {0.f, 0.f, 9.f}, 0.5f);
    setVoxel(volume, 1, {10, -10, 2}, 0.f, {5.f, 5.f, 5.f}, 1.f); // no mass: stays empty
    setVoxel(volume, 2, {20, 20, 20}, 0.f, {5.f, 5.f, 5.f}, 1.f);
    writeVolumeCache(dir.str(), info, volume, {"density", "velocity", "failed"});

    const std::string path = dir.file("volume.0012.vdb");
    CHECK_FALSE(hasTempFile(dir.str()));
    const auto grids = readGrids(path);
    REQUIRE(grids->size() == 3);
    const auto density = gridNamed<openvdb::FloatGrid>(*grids, "density");
    const auto velocity = gridNamed<openvdb::Vec3fGrid>(*grids, "velocity");
    const auto failed = gridNamed<openvdb::FloatGrid>(*grids, "failed");
    REQUIRE((density && velocity && failed));

    CHECK(density->getGridClass() == openvdb::GRID_FOG_VOLUME);
    CHECK(density->background() == 0.f);
    CHECK(velocity->getVectorType() == openvdb::VEC_CONTRAVARIANT_RELATIVE);
    for (const auto& grid : *grids) {
        INFO(grid->getName());
        checkFrameMetadata(*grid, info);
        CHECK(grid->activeVoxelCount() == massiveVoxels(volume));
        CHECK(grid->baseTree().leafCount() == 2);
        CHECK(grid->voxelSize()[0] == Approx(dx).epsilon(1e-12));
    }
    CHECK(valueAtNode(*density, {0, 0, 0}, dx) == 300.f);
    CHECK(valueAtNode(*density, {7, 1, 5}, dx) == 250.5f);
    CHECK(valueAtNode(*density, {15, -16, 7}, dx) == 1e-3f);
    CHECK(valueAtNode(*velocity, {9, -9, 3}, dx) == openvdb::Vec3f(0.f, -4.f, 0.f));
    CHECK(valueAtNode(*velocity, {7, 1, 5}, dx) == openvdb::Vec3f(-1.f, 0.f, 0.5f));
    CHECK(valueAtNode(*failed, {9, -9, 3}, dx) == 0.25f);
    CHECK(valueAtNode(*failed, {7, 1, 5}, dx) == 1.f);
    CHECK(valueAtNode(*velocity, {10, -10, 2}, dx) == openvdb::Vec3f(0.f));
    CHECK_FALSE(velocity->tree().isValueOn({10, -10, 2}));
    CHECK_THAT(fileCompression(*density), Catch::Contains("blosc"));
}

TEST_CASE("volume cache in 2D writes only the grids asked for", "[io]") {
    TempDir dir;
    const double dx = 0.025;
    VolumeFrame volume = makeVolume({{-8, 0, 0}}, dx);
    for (int x = -8; x < 0; ++x) {
        for (int y = 0; y < 3; ++y) {
            setVoxel(volume, 0, {x, y, 0}, 400.f + float(x + y), {float(x), float(y), 0.f}, 0.f);
        }
    }
    writeVolumeCache(dir.str(), {1, 1.0 / 24.0, 24.0}, volume, {"failed", "density"});

    const auto grids = readGrids(dir.file("volume.0001.vdb"));
    REQUIRE(grids->size() == 2);
    CHECK((*grids)[0]->getName() == "density"); // outputs.md order
    CHECK((*grids)[1]->getName() == "failed");
    const auto density = gridNamed<openvdb::FloatGrid>(*grids, "density");
    REQUIRE(density);
    CHECK(density->activeVoxelCount() == 24);
    const openvdb::CoordBBox box = density->evalActiveVoxelBoundingBox();
    CHECK(box == openvdb::CoordBBox({-8, 0, 0}, {-1, 2, 0}));
    CHECK(valueAtNode(*density, {-3, 2, 0}, dx) == 399.f);
}

TEST_CASE("volume cache rejects malformed input", "[io]") {
    TempDir dir;
    VolumeFrame volume = makeVolume({{0, 0, 0}}, 0.1);
    CHECK_THROWS_AS(writeVolumeCache(dir.str(), {}, volume, {"temperature"}),
                    std::invalid_argument);
    volume.origin[0] = {4, 0, 0};
    CHECK_THROWS_AS(writeVolumeCache(dir.str(), {}, volume, {"density"}), std::invalid_argument);
    volume.origin[0] = {0, 0, 0};
    volume.velocity.clear();
    CHECK_THROWS_AS(writeVolumeCache(dir.str(), {}, volume, {"velocity"}), std::invalid_argument);
    CHECK_NOTHROW(writeVolumeCache(dir.str(), {}, volume, {"density"}));
    CHECK_THROWS_AS(writeVolumeCache(dir.file("missing"), {}, volume, {"density"}), IoError);
}

TEST_CASE("vdb_print lists the grids of our caches", "[io]") {
    if (!fs::exists("/usr/bin/vdb_print")) {
        WARN("vdb_print not installed (Debian libopenvdb-tools): skipped");
        return;
    }
    TempDir dir;
    writeParticleCache(dir.str(), {4, 0.2, 24.0}, 0.05, makeParticles(100, 1.f, 6));
    VolumeFrame volume = makeVolume({{0, 0, 0}}, 0.05);
    setVoxel(volume, 0, {1, 2, 3}, 100.f, {0.f, 0.f, 0.f}, 0.f);
    writeVolumeCache(dir.str(), {4, 0.2, 24.0}, volume, {"density", "velocity", "failed"});

    const std::string points = vdbPrint(dir.file("particles.0004.vdb"));
    INFO(points);
    CHECK_THAT(points, Catch::Contains("points") && Catch::Contains("ptdataidx32"));
    CHECK_THAT(points, Catch::Contains("time") && Catch::Contains("frame_rate"));
    const std::string volumes = vdbPrint(dir.file("volume.0004.vdb"));
    INFO(volumes);
    CHECK_THAT(volumes, Catch::Contains("density") && Catch::Contains("velocity") &&
                            Catch::Contains("failed"));
}

////////////////////////////////////////

// Text outputs

TEST_CASE("frameFileName pads frames to four digits", "[io]") {
    CHECK(frameFileName("particles", 0) == "particles.0000.vdb");
    CHECK(frameFileName("volume", 37) == "volume.0037.vdb");
    CHECK(frameFileName("particles", 12345) == "particles.12345.vdb");
    CHECK_THROWS_AS(frameFileName("particles", -1), std::invalid_argument);
}

TEST_CASE("formatNumber gives the shortest text that reads back the same", "[io]") {
    for (const double x : {0.1, 1e-300, 123456789.123, -0.0, 1.0 / 3.0, 0.1 + 0.2, 1e-6, 2.5e-7,
                           5e-324, DBL_MAX, -DBL_MIN, 1e15, 1e6, -42.0, 299792458.0}) {
        const std::string text = formatNumber(x);
        INFO(text);
        const double back = std::strtod(text.c_str(), nullptr);
        CHECK(std::memcmp(&back, &x, sizeof x) == 0); // bit for bit: -0 keeps its sign
    }
    CHECK(formatNumber(0.1) == "0.1");
    CHECK(formatNumber(1e-300) == "1e-300");
    CHECK(formatNumber(123456789.123) == "123456789.123");
    CHECK(formatNumber(-0.0) == "-0");
    CHECK(formatNumber(1e-6) == "1e-06");
    CHECK(formatNumber(0.1 + 0.2) == "0.30000000000000004");
    CHECK(formatNumber(1000000.0) == "1000000");
    CHECK(formatNumber(std::nan("")) == "");
    CHECK(formatNumber(std::numeric_limits<double>::infinity()) == "");
    CHECK(formatNumber(-std::numeric_limits<double>::infinity()) == "");
}

TEST_CASE("JsonObject escapes strings, writes null for non-finite numbers", "[io]") {
    JsonObject json;
    json.set("scene", "pst \"slab\"\\weak\nlayer\t\x01 \xc3\xa9");
    json.set("particles", 120000);
    json.set("peak_rss_bytes", 12345678901LL);
    json.set("end_time", 2.5);
    json.set("max_crack_speed", std::numeric_limits<double>::quiet_NaN());
    json.set("runout_x", -std::numeric_limits<double>::infinity());
    json.setNull("alpha_angle_deg");
    json.set("status", std::string("ok"));
    json.set("end_time", 3.0); // a key set again keeps its place
    CHECK(json.str() == "{\n"
                        "  \"scene\": \"pst \\\"slab\\\"\\\\weak\\nlayer\\t\\u0001 \xc3\xa9\",\n"
                        "  \"particles\": 120000,\n"
                        "  \"peak_rss_bytes\": 12345678901,\n"
                        "  \"end_time\": 3,\n"
                        "  \"max_crack_speed\": null,\n"
                        "  \"runout_x\": null,\n"
                        "  \"alpha_angle_deg\": null,\n"
                        "  \"status\": \"ok\"\n"
                        "}\n");
    CHECK(JsonObject().str() == "{}\n");
}

TEST_CASE("MetricsWriter writes the header at once and flushes every row", "[io]") {
    TempDir dir;
    const std::string path = dir.file("metrics.csv");
    MetricsWriter metrics(path, {"frame", "time", "crack_tip_x"});
    CHECK(readText(path) == "frame,time,crack_tip_x\n");
    metrics.appendRow({"0", formatNumber(0.0), ""});
    metrics.appendRow({"1", formatNumber(1.0 / 24.0), formatNumber(-1.5)});
    CHECK(readText(path) == "frame,time,crack_tip_x\n0,0,\n1,0.041666666666666664,-1.5\n");
    CHECK_THROWS_AS(metrics.appendRow({"2", "0.1"}), std::logic_error);
}

TEST_CASE("MetricsWriter failures are IoErrors naming the path", "[io]") {
    TempDir dir;
    const std::string missing = dir.file("no_such_folder/metrics.csv");
    CHECK_THROWS_AS(MetricsWriter(missing, {"frame"}), IoError);
    CHECK_THROWS_WITH(MetricsWriter(missing, {"frame"}), Catch::Contains(missing));
    std::ofstream(dir.file("plain_file")) << "x";
    CHECK_THROWS_WITH(MetricsWriter(dir.file("plain_file/metrics.csv"), {"frame"}),
                      Catch::Contains("plain_file/metrics.csv") &&
                          Catch::Contains("Not a directory"));
    // /dev/full accepts the open and fails every write, like a full disk.
    if (fs::exists("/dev/full")) {
        CHECK_THROWS_WITH(MetricsWriter("/dev/full", {"frame"}),
                          Catch::Contains("/dev/full") &&
                              Catch::Contains("No space left on device"));
    }
}

TEST_CASE("writeFileAtomic replaces a file whole and leaves no temporary", "[io]") {
    TempDir dir;
    const std::string path = dir.file("summary.json");
    writeFileAtomic(path, "first\n");
    writeFileAtomic(path, "{\n  \"status\": \"ok\"\n}\n");
    CHECK(readText(path) == "{\n  \"status\": \"ok\"\n}\n");
    CHECK(fileNames(dir.str()) == std::vector<std::string>{"summary.json"});
    const std::string missing = dir.file("missing/summary.json");
    CHECK_THROWS_WITH(writeFileAtomic(missing, "x"), Catch::Contains(missing));
}

TEST_CASE("makeDirectories creates parents and reports what it cannot create", "[io]") {
    TempDir dir;
    const std::string nested = dir.file("out/pst/frames");
    makeDirectories(nested);
    CHECK(fs::is_directory(nested));
    CHECK_NOTHROW(makeDirectories(nested)); // already there
    std::ofstream(dir.file("plain_file")) << "x";
    CHECK_THROWS_AS(makeDirectories(dir.file("plain_file")), IoError);
    CHECK_THROWS_WITH(makeDirectories(dir.file("plain_file/frames")),
                      Catch::Contains("plain_file/frames"));
}
