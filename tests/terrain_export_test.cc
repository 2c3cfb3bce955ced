// Terrain export: the level set terrain.vdb and the mesh terrain.obj against known grounds.
#include "test_util.h"

#include <firn/terrain_export.h>

#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <openvdb/openvdb.h>
#include <openvdb/tools/Interpolation.h>

#include <cmath>
#include <fstream>
#include <sstream>

using namespace firn;

namespace {

/// The plane through (0, 1, 0) with normal (0.3, 1, 0.2): y = 1 - 0.3 x - 0.2 z.
Collider tiltedPlane() {
    TerrainDesc desc;
    desc.shape = TerrainShape::Plane;
    desc.point = {0.0, 1.0, 0.0};
    const double len = std::sqrt(0.09 + 1.0 + 0.04);
    desc.normal = {0.3 / len, 1.0 / len, 0.2 / len};
    return Collider::fromDesc(desc, 3);
}

double planeHeight(double x, double z) {
    return 1.0 - 0.3 * x - 0.2 * z;
}

openvdb::FloatGrid::Ptr readSurface(const std::string& path) {
    openvdb::initialize();
    openvdb::io::File file(path);
    file.open();
    const openvdb::GridPtrVecPtr grids = file.getGrids();
    file.close();
    REQUIRE(grids->size() == 1);
    auto grid = openvdb::gridPtrCast<openvdb::FloatGrid>(grids->front());
    REQUIRE(grid);
    return grid;
}

/// Height of the level set's zero crossing above (x, z), by bisection on the trilinear
/// interpolant between two heights that bracket it.
double zeroCrossing(const openvdb::FloatGrid& grid, double x, double z, double lo, double hi) {
    const openvdb::tools::GridSampler<openvdb::FloatGrid, openvdb::tools::BoxSampler> sample(grid);
    REQUIRE(sample.wsSample(openvdb::Vec3d(x, lo, z)) < 0.f);
    REQUIRE(sample.wsSample(openvdb::Vec3d(x, hi, z)) > 0.f);
    for (int it = 0; it < 60; ++it) {
        const double mid = 0.5 * (lo + hi);
        (sample.wsSample(openvdb::Vec3d(x, mid, z)) < 0.f ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

struct Obj {
    std::vector<Vec3f> vertices, normals;
    std::vector<std::array<int, 3>> faces; // 0-based vertex indices
    std::string header;
};

Obj readObj(const std::string& path) {
    Obj obj;
    std::ifstream in(path);
    REQUIRE(in);
    for (std::string line; std::getline(in, line);) {
        std::istringstream s(line);
        std::string tag;
        s >> tag;
        if (tag == "#") obj.header += line + "\n";
        if (tag == "v" || tag == "vn") {
            Vec3f p;
            s >> p[0] >> p[1] >> p[2];
            (tag == "v" ? obj.vertices : obj.normals).push_back(p);
        }
        if (tag == "f") {
            std::array<int, 3> f{};
            for (int& index : f) {
                std::string corner;
                s >> corner; // "v//vn"
                index = std::stoi(corner) - 1;
                CHECK(corner.substr(corner.find("//") + 2) == std::to_string(index + 1));
            }
            obj.faces.push_back(f);
        }
    }
    return obj;
}

} // namespace

TEST_CASE("terrain level set of a tilted plane crosses zero on the plane", "[terrain]") {
    test::TempDir dir("firn-terrain");
    const std::vector<Collider> ground{tiltedPlane()};
    const double h = 0.1;
    const TerrainExtent extent{0.0, 2.0, -0.5, 1.0};
    const std::string path = dir.path() + "/terrain.vdb";
    writeTerrainLevelSet(path, ground, extent, h, 24.0);
    const auto grid = readSurface(path);

    CHECK(grid->getName() == "surface");
    CHECK(grid->getGridClass() == openvdb::GRID_LEVEL_SET);
    CHECK(grid->voxelSize()[0] == Approx(h).epsilon(1e-12));
    CHECK(grid->background() == Approx(3 * h));
    CHECK(grid->getCreator() == "firn");
    CHECK(grid->metaValue<double>("time") == 0.0);
    CHECK(grid->metaValue<int32_t>("frame") == 0);
    CHECK(grid->metaValue<double>("frame_rate") == 24.0);
    CHECK(grid->metaValue<std::string>(openvdb::GridBase::META_FILE_COMPRESSION) ==
          "blosc + active values");

    // The narrow band: every active value is the signed distance, within 3 voxels.
    for (auto it = grid->cbeginValueOn(); it; ++it) {
        const openvdb::Vec3d p = grid->indexToWorld(it.getCoord());
        REQUIRE(std::abs(*it) < 3 * h);
        REQUIRE(*it == Approx(ground[0].signedDistance(Vec3f(p.x(), p.y(), p.z()))).margin(1e-5));
    }
    // Signs away from the band: below the ground inside, above outside.
    CHECK(grid->tree().getValue(grid->transform().worldToIndexCellCentered({1, -3, 0})) < 0.f);
    CHECK(grid->tree().getValue(grid->transform().worldToIndexCellCentered({1, 4, 0})) > 0.f);

    // The zero crossing matches the plane to a small fraction of a voxel over the whole extent.
    for (double x : {0.0, 0.37, 1.0, 1.55, 2.0})
        for (double z : {-0.5, 0.12, 0.5, 1.0}) {
            INFO("x = " << x << ", z = " << z);
            const double y =
                zeroCrossing(*grid, x, z, planeHeight(x, z) - 2 * h, planeHeight(x, z) + 2 * h);
            CHECK(std::abs(y - planeHeight(x, z)) < 0.01 * h);
        }
}

TEST_CASE("terrain mesh of a tilted plane lies on the plane, faces up", "[terrain]") {
    test::TempDir dir("firn-terrain-obj");
    const std::vector<Collider> ground{tiltedPlane()};
    const TerrainExtent extent{0.0, 2.0, -0.5, 1.0};
    const std::string path = dir.path() + "/terrain.obj";
    writeTerrainObj(path, ground, extent, 0.25, "a note\nsecond line");
    const Obj obj = readObj(path);

    CHECK_THAT(obj.header, Catch::Contains("# a note\n# second line\n"));
    const int nx = 8, nz = 6; // 2 m and 1.5 m at 0.25 m
    REQUIRE(obj.vertices.size() == std::size_t((nx + 1) * (nz + 1)));
    REQUIRE(obj.normals.size() == obj.vertices.size());
    REQUIRE(obj.faces.size() == std::size_t(2 * nx * nz));
    const Vec3f n(0.3f, 1.f, 0.2f);
    for (std::size_t v = 0; v < obj.vertices.size(); ++v) {
        const Vec3f& p = obj.vertices[v];
        REQUIRE(std::abs(ground[0].signedDistance(p)) < 1e-6f);
        REQUIRE(p[0] >= -1e-6f);
        REQUIRE(p[0] <= 2.f + 1e-6f);
        REQUIRE(p[2] >= -0.5f - 1e-6f);
        REQUIRE(p[2] <= 1.f + 1e-6f);
        REQUIRE(obj.normals[v].dot(n.normalized()) == Approx(1.0).margin(1e-5));
    }
    double area = 0.0;
    for (const auto& f : obj.faces) {
        const Vec3f& a = obj.vertices[f[0]];
        const Vec3f cross = (obj.vertices[f[1]] - a).cross(obj.vertices[f[2]] - a);
        REQUIRE(cross.normalized().dot(n.normalized()) == Approx(1.0).margin(1e-5));
        area += 0.5 * cross.norm();
    }
    CHECK(area == Approx(2.0 * 1.5 * n.norm()).epsilon(1e-5)); // covers the whole extent
}

TEST_CASE("2D terrain is the ground line extruded across z", "[terrain]") {
    const SceneDesc scene = test::sceneFromText(R"(
[simulation]
dimension = 2
end_time = 2.0
gravity = [0.0, -9.81]
[grid]
dx = 0.1
[[material]]
name = "snow"
model = "granular"
[[terrain]]
shape = "profile"
points = [[0.0, 4.0], [4.0, 1.0], [10.0, 0.0]]
[[body]]
material = "snow"
shape = "layer"
thickness = 0.3
x_range = [1.0, 3.0]
)");
    const auto world = buildWorld(scene);
    // Free fall over 2 s would reach ~20 m: the profile's range, grown by 10 %, bounds it.
    const TerrainExtent e = terrainExtent(scene);
    CHECK(e.x0 == Approx(-1.0));
    CHECK(e.x1 == Approx(11.0));
    CHECK(e.z0 == Approx(-0.2 * 12.0 / 2));
    CHECK(e.z1 == Approx(0.2 * 12.0 / 2));

    test::TempDir dir("firn-terrain-2d");
    exportTerrain(scene, world->colliders, dir.path());
    const Obj obj = readObj(dir.path() + "/terrain.obj");
    CHECK_THAT(obj.header, Catch::Contains("2D run"));
    float zMin = 1e9f, zMax = -1e9f;
    for (const Vec3f& p : obj.vertices) {
        REQUIRE(std::abs(world->colliders[0].signedDistance(p)) < 1e-5f);
        zMin = std::min(zMin, p[2]), zMax = std::max(zMax, p[2]);
    }
    CHECK(zMin == Approx(e.z0));
    CHECK(zMax == Approx(e.z1));

    const auto grid = readSurface(dir.path() + "/terrain.vdb");
    CHECK(grid->voxelSize()[0] == Approx(0.1));
    // The same crossing at both ends of the extrusion and in the middle (1.75 m at x = 3).
    for (double z : {e.z0, 0.0, e.z1}) {
        INFO("z = " << z);
        CHECK(zeroCrossing(*grid, 3.0, z, 1.5, 2.0) == Approx(1.75).margin(0.01 * 0.1));
    }
    // Below the ground is inside everywhere over the extent, far below the band too: the
    // renderer draws a 2D run's ground from the sign (a node of the tree without band voxels,
    // below the run-out and left of x = 0, was once flood-filled as outside).
    const auto height = [](double x) { return x < 4.0 ? 4.0 - 0.75 * x : 1.0 - (x - 4.0) / 6.0; };
    for (double x : {-0.95, -0.5, 0.5, 3.0, 7.0, 10.95})
        for (double depth : {0.5, 2.0, 6.0, 12.0}) {
            const openvdb::Vec3d p(x, std::min(height(std::max(x, 0.0)), 0.0) - depth, 0.0);
            INFO("x " << x << ", y " << p[1]);
            CHECK(grid->tree().getValue(grid->transform().worldToIndexCellCentered(p)) < 0.f);
        }

    // A long path (scenes/path2d: a 30 m release on a 600 m profile): the whole profile, not
    // 10 release sizes around the release (here 2 m: 20 m).
    SceneDesc path = scene;
    path.terrains[0].points = {{0.0, 40.0}, {40.0, 10.0}, {100.0, 0.0}};
    path.simulation.endTime = 30.0;
    const TerrainExtent whole = terrainExtent(path);
    CHECK(whole.x0 == Approx(-10.0));
    CHECK(whole.x1 == Approx(110.0));
    // ... as far as a free fall could reach: 0.3 s reach 0.44 m.
    path.simulation.endTime = 0.3;
    const double fall = 0.5 * 9.81 * 0.3 * 0.3;
    CHECK(terrainExtent(path).x1 == Approx(3.0 + fall));
}

TEST_CASE("terrain extent: the reach of a free fall around the bodies, coarser when large",
          "[terrain]") {
    SceneDesc scene;
    scene.simulation.dimension = 3;
    scene.simulation.endTime = 1.0;
    scene.simulation.gravity = {0.0, -9.81, 0.0};
    BodyDesc block;
    block.shape = BodyShape::Box;
    block.min = {0.0, 0.0, 0.0};
    block.max = {1.0, 0.25, 0.5};
    block.velocity = {2.0, 0.0, 0.0};
    scene.bodies.push_back(block);
    const double reach = 2.0 * 1.0 + 0.5 * 9.81;
    TerrainExtent e = terrainExtent(scene);
    CHECK(e.x0 == Approx(-reach));
    CHECK(e.x1 == Approx(1.0 + reach));
    CHECK(e.z0 == Approx(-reach));
    CHECK(e.z1 == Approx(0.5 + reach));

    scene.simulation.endTime = 100.0; // capped at 10 sizes of the release
    e = terrainExtent(scene);
    CHECK(e.x0 == Approx(-10.0));
    CHECK(e.x1 == Approx(11.0));

    CHECK(exportSpacing(e, 0.05, 1e9) == Approx(0.05));
    const double coarse = exportSpacing(e, 0.05, 100.0 * 100.0); // 21 m at <= 100 cells
    CHECK(coarse == Approx(0.25));
}

TEST_CASE("a scene without ground writes no terrain and removes an old one", "[terrain]") {
    test::TempDir dir("firn-terrain-none");
    std::ofstream(dir.path() + "/terrain.obj") << "stale";
    std::ofstream(dir.path() + "/terrain.vdb") << "stale";
    SceneDesc scene;
    BodyDesc block;
    block.max = {1.0, 1.0, 1.0};
    scene.bodies.push_back(block);
    exportTerrain(scene, {}, dir.path());
    CHECK_FALSE(std::filesystem::exists(dir.path() + "/terrain.obj"));
    CHECK_FALSE(std::filesystem::exists(dir.path() + "/terrain.vdb"));
}
