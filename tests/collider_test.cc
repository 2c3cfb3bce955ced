// Terrain colliders: planes, profiles and ESRI ASCII heightfields; boundary conditions.
#include "test_util.h"

#include <firn/collider.h>
#include <firn/dem.h>

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <random>

using namespace firn;

namespace {

/// A DEM of the plane y = 0.5 x + 0.25 z + 2 on 5 m cells, corner convention.
std::string writeTiltedDem(const std::string& dir, const std::string& extraRow = "") {
    const std::string path = dir + "/tilted.asc";
    std::ofstream out(path);
    out << "ncols 6\nnrows 4\nxllcorner -2.5\nyllcorner -2.5\ncellsize 5\nNODATA_value -9999\n";
    for (int fileRow = 0; fileRow < 4; ++fileRow) {
        const double z = (3 - fileRow) * 5.0; // the first row is the northernmost
        for (int c = 0; c < 6; ++c) out << 0.5 * (c * 5.0) + 0.25 * z + 2.0 << " ";
        out << "\n";
    }
    out << extraRow;
    return path;
}

} // namespace

TEST_CASE("an ESRI ASCII heightfield reproduces a planar terrain", "[collider]") {
    test::TempDir dir("firn-dem");
    TerrainDesc desc;
    desc.shape = TerrainShape::Heightfield;
    desc.file = writeTiltedDem(dir.path());
    const Collider ground = Collider::fromDesc(desc, 3);
    // Bilinear interpolation is exact on a plane; float heights: 1e-4 m.
    for (float x : {0.f, 3.3f, 12.7f, 24.9f})
        for (float z : {0.f, 7.1f, 14.9f}) {
            REQUIRE(ground.heightAt(x, z) == Approx(0.5 * x + 0.25 * z + 2.0).margin(1e-4));
            const Vec3f p(x, 0.5f * x + 0.25f * z + 2.f + 1.f, z); // 1 m above, vertically
            const double cosSlope = 1.0 / std::sqrt(1.0 + 0.25 + 0.0625);
            REQUIRE(ground.signedDistance(p) == Approx(cosSlope).margin(1e-4));
            const Vec3f n = ground.normal(p);
            REQUIRE(n[0] == Approx(-0.5 * cosSlope).margin(1e-5));
            REQUIRE(n[1] == Approx(cosSlope).margin(1e-5));
            REQUIRE(n[2] == Approx(-0.25 * cosSlope).margin(1e-5));
        }
    REQUIRE(ground.signedDistance(Vec3f(5.f, 0.f, 5.f)) < 0.f); // below ground
}

TEST_CASE("a bad DEM names the file and line", "[collider]") {
    test::TempDir dir("firn-dem-bad");
    TerrainDesc desc;
    desc.shape = TerrainShape::Heightfield;
    desc.file = dir.path() + "/holes.asc";
    {
        std::ofstream out(desc.file);
        out << "ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\nNODATA_value -9999\n"
               "1 2\n3 -9999\n";
    }
    REQUIRE_THROWS_WITH(Collider::fromDesc(desc, 3),
                        desc.file + ":8: error: heightfield: NODATA cell at row 2, column 2: "
                                    "fill the DEM first, or set nodata = \"fill\" on the terrain");
    {
        std::ofstream out(desc.file);
        out << "ncols 3\nnrows 2\nxllcorner 0\ncellsize 1\n1 2 3\n4 5 6\n";
    }
    REQUIRE_THROWS_WITH(Collider::fromDesc(desc, 3),
                        desc.file + ":4: error: heightfield: missing 'yllcorner'");
}

// The fuzz target's findings (fuzz/regressions/dem): each once crashed, allocated the header's
// cell count before reading any data, or gave the collider non-finite heights and slopes.
TEST_CASE("a DEM outside what the collider can hold is rejected", "[collider]") {
    const auto errorOf = [](const std::string& text) -> std::string {
        try {
            Heightfield::parseEsriAscii(text, "d.asc");
        } catch (const SceneError& e) {
            return e.what();
        }
        return "no error";
    };
    const std::string corner = "xllcorner 0\nyllcorner 0\n";
    CHECK(errorOf("ncols 3e9\nnrows 2\n" + corner + "cellsize 1\n1 2\n") ==
          "d.asc:1: error: heightfield: needs ncols >= 2, nrows >= 2 and cellsize > 0");
    CHECK(errorOf("ncols 2\nnrows 2e9\n" + corner + "cellsize 2\n") ==
          "d.asc:6: error: heightfield: expected 4000000000 heights, the data ends in row 1");
    CHECK(errorOf("ncols 2.5\nnrows 2\n" + corner + "cellsize 1\n1 2\n3 4\n") ==
          "d.asc:1: error: heightfield: ncols and nrows must be whole numbers");
    CHECK(errorOf("ncols 2\nnrows 2\n" + corner + "cellsize 5e-320\n1 2\n3 4\n") ==
          "d.asc:1: error: heightfield: cellsize must be in [1e-06, 1e+06] m");
    CHECK(errorOf("ncols 2\nnrows 2\n" + corner + "cellsize 1\n1 2\n3 7e38\n") ==
          "d.asc:7: error: heightfield: height 7e+38 at row 2, column 2 is not within 1e+06 m "
          "of 0");
    // A data row may start with '+'; before, it was read as a header key.
    const Heightfield h = Heightfield::parseEsriAscii(
        "ncols 2\nnrows 2\nxllcenter 0\nyllcenter 0\ncellsize 1\n+1 +2\n3 4\n", "d.asc");
    CHECK(h.heightAt(0.f, 1.f) == 1.f); // the first row is the northernmost
    CHECK(h.heightAt(1.f, 0.f) == 4.f);
}

TEST_CASE("Coulomb friction on a grid node: stick, slip, separate", "[collider]") {
    TerrainDesc desc;
    desc.friction = 0.5;
    const Collider ground = Collider::fromDesc(desc, 3);
    const Vec3f n(0.f, 1.f, 0.f);
    // |v_t| = 0.4 <= mu |v_n| = 0.5: sticks
    REQUIRE(ground.applyBoundary(Vec3f(0.4f, -1.f, 0.f), n).norm() == 0.f);
    // |v_t| = 2: slides with |v_t| - mu |v_n| = 1.5
    const Vec3f slid = ground.applyBoundary(Vec3f(2.f, -1.f, 0.f), n);
    REQUIRE(slid[0] == Approx(1.5f));
    REQUIRE(slid[1] == 0.f);
    // separating: untouched
    REQUIRE(ground.applyBoundary(Vec3f(2.f, 1.f, 0.f), n) == Vec3f(2.f, 1.f, 0.f));
    desc.boundary = Boundary::Slip;
    REQUIRE(Collider::fromDesc(desc, 3).applyBoundary(Vec3f(2.f, -1.f, 0.f), n) ==
            Vec3f(2.f, 0.f, 0.f));
}

TEST_CASE("a layer drapes over a heightfield", "[collider][setup]") {
    test::TempDir dir("firn-dem-layer");
    const std::string dem = writeTiltedDem(dir.path());
    const std::string text =
        "[simulation]\nname = \"dem\"\ndimension = 3\n[grid]\ndx = 0.25\nparticles_per_cell = 1\n"
        "[[material]]\nname = \"snow\"\nmodel = \"elastic\"\n"
        "[[terrain]]\nshape = \"heightfield\"\nfile = \"" +
        dem +
        "\"\n"
        "[[body]]\nmaterial = \"snow\"\nshape = \"layer\"\nthickness = 0.5\n"
        "x_range = [2.0, 8.0]\nz_range = [2.0, 6.0]\n";
    auto world = buildWorld(test::sceneFromText(text, "dem"));
    const ParticleSet& ps = world->particles;
    REQUIRE(ps.size() > 100);
    const double cosSlope = 1.0 / std::sqrt(1.0 + 0.25 + 0.0625);
    for (std::size_t i = 0; i < ps.size(); ++i) {
        const Vec3f& p = ps.x[i];
        const double above = (p[1] - (0.5 * p[0] + 0.25 * p[2] + 2.0)) * cosSlope;
        REQUIRE(above >= -1e-4);
        REQUIRE(above < 0.5 + 1e-4);
    }
}

namespace {

/// A shear flow v = s d t over a sticky plane through the origin with unit normal n (d: distance
/// from the plane, t: the plane's tangent closest to x), given to the particles with its exact
/// APIC gradient, transferred once (P2G, grid update, G2P; no gravity, no stress). Returns the
/// mean relative error of the shear rate t.C.n that the particles within 1.5 cells of the plane
/// read back, and (in `bulkError`) the same for those more than 3 cells from any edge.
double nearWallShearError(int dim, const Vec3f& n, double& bulkError) {
    const Vec3f t = (Vec3f::UnitX() - n[0] * n).normalized();
    auto vec = [&](const Vec3f& v) {
        return "[" + std::to_string(v[0]) + ", " + std::to_string(v[1]) +
               (dim == 3 ? ", " + std::to_string(v[2]) : std::string()) + "]";
    };
    const std::string text =
        "[simulation]\nname = \"shear\"\ndimension = " + std::to_string(dim) +
        "\nend_time = 1.0\ngravity = " + vec(Vec3f::Zero()) +
        "\nsettle = false\n[grid]\ndx = 0.1\nparticles_per_cell = " + (dim == 3 ? "8" : "4") +
        "\njitter = 0.0\n[[material]]\nname = \"m\"\nmodel = \"elastic\"\n"
        "[[terrain]]\nshape = \"plane\"\npoint = " +
        vec(Vec3f::Zero()) + "\nnormal = " + vec(n) +
        "\nboundary = \"sticky\"\n"
        "[[body]]\nmaterial = \"m\"\nshape = \"layer\"\nthickness = 1.0\nx_range = [0.0, 3.0]\n" +
        (dim == 3 ? "z_range = [0.0, 1.2]\n" : "");
    auto w = buildWorld(test::sceneFromText(text, "shear"));
    const float s = 2.f; // 1/s
    ParticleSet& ps = w->particles;
    for (std::size_t i = 0; i < ps.size(); ++i) {
        ps.v[i] = s * n.dot(ps.x[i]) * t;
        ps.C[i] = s * t * n.transpose();
    }
    step(*w, 1e-5);
    double wall = 0, bulk = 0;
    int nWall = 0, nBulk = 0;
    for (std::size_t i = 0; i < ps.size(); ++i) {
        const float d = n.dot(ps.x[i]), along = t.dot(ps.x[i]), z = ps.x[i][2];
        if (along < 0.3f || along > 2.7f || (dim == 3 && (z < 0.3f || z > 0.9f))) continue;
        const double error = std::abs(t.dot(ps.C[i] * n) / s - 1.0);
        if (d < 0.15f) wall += error, ++nWall;
        if (d > 0.3f && d < 0.7f) bulk += error, ++nBulk;
    }
    REQUIRE(nWall > 20);
    REQUIRE(nBulk > 20);
    bulkError = bulk / nBulk;
    return wall / nWall;
}

} // namespace

TEST_CASE("a sticky wall reproduces a shear flow that grows linearly from it", "[collider]") {
    // Nodes inside a sticky collider take the negated velocity of their mirror image
    // (firn/sticky_walls.h). Zeroing them instead gave the particles in the first 1.5 cells a
    // shear rate 5.2 % low on average on the aligned wall (the row a quarter cell from the wall
    // reads 3/4 of it): the test fails without the mirror. Measured with it: 2e-7 (aligned, 2D
    // and 3D), 1.7 % (2D, 30 deg), 1.2 % (3D, a plane tilted about two axes).
    struct Case {
        int dim;
        Vec3f normal;
        double tolerance;
    };
    const float c30 = std::cos(0.5236f), s30 = std::sin(0.5236f);
    // A wall through grid nodes mirrors node onto node: exact to rounding. A tilted wall
    // interpolates its mirrors (bi- or trilinearly) and drops mirror corners inside the wall.
    for (const Case& c : {Case{2, Vec3f(0.f, 1.f, 0.f), 1e-3}, Case{2, Vec3f(-s30, c30, 0.f), 0.05},
                          Case{3, Vec3f(0.f, 1.f, 0.f), 1e-3},
                          Case{3, Vec3f(-0.5f, 0.8f, 0.33f).normalized(), 0.05}}) {
        double bulkError = 0;
        const double wallError = nearWallShearError(c.dim, c.normal, bulkError);
        INFO(c.dim << "D, normal " << c.normal.transpose() << ": mean relative error of the shear "
                   << "rate " << wallError << " near the wall, " << bulkError << " in the bulk");
        // APIC carries a linear field exactly: the bulk to float rounding of one transfer.
        REQUIRE(bulkError < 1e-3);
        REQUIRE(wallError < c.tolerance);
    }
}

TEST_CASE("a profile's distance and normal are those of its nearest segment", "[collider]") {
    // The nearest point is searched outwards from the segment under the point (collider.cc);
    // the reference scans every segment in double precision. A search that stopped too early
    // would pick a farther segment: off by centimetres to metres on this rough profile, where
    // float rounding is ~1e-5 m at its 300 m extent.
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> spacing(0.05, 3.0), step(-2.0, 2.0), unit(0.0, 1.0);
    TerrainDesc desc;
    desc.shape = TerrainShape::Profile;
    double x = -40.0, y = 50.0;
    for (int i = 0; i < 240; ++i) {
        desc.points.push_back({x, y});
        x += spacing(rng), y += step(rng) - 0.3;
    }
    const Collider collider = Collider::fromDesc(desc, 2);
    std::vector<std::array<double, 2>> profile;
    for (const auto& p : desc.points) profile.push_back({double(float(p[0])), double(float(p[1]))});
    const std::size_t ns = profile.size() - 1;
    const auto reference = [&](double px, double py, double& distance, Eigen::Vector3d& normal) {
        double best = std::numeric_limits<double>::max(), cx = 0.0, cy = 0.0;
        for (std::size_t s = 0; s < ns; ++s) {
            const double ax = profile[s][0], ay = profile[s][1];
            const double ex = profile[s + 1][0] - ax, ey = profile[s + 1][1] - ay;
            double t = ((px - ax) * ex + (py - ay) * ey) / (ex * ex + ey * ey);
            if (s > 0) t = std::max(t, 0.0);
            if (s + 1 < ns) t = std::min(t, 1.0);
            const double d2 = std::pow(px - ax - t * ex, 2) + std::pow(py - ay - t * ey, 2);
            if (d2 < best) best = d2, cx = ax + t * ex, cy = ay + t * ey;
        }
        std::size_t s = 0;
        while (s + 1 < ns && px > profile[s + 1][0]) ++s;
        const double ground = profile[s][1] + (profile[s + 1][1] - profile[s][1]) *
                                                  (px - profile[s][0]) /
                                                  (profile[s + 1][0] - profile[s][0]);
        const double sign = py >= ground ? 1.0 : -1.0;
        distance = sign * std::sqrt(best);
        normal = Eigen::Vector3d(sign * (px - cx), sign * (py - cy), 0.0) /
                 std::max(std::sqrt(best), 1e-30);
    };
    const double x0 = profile.front()[0] - 30.0, x1 = profile.back()[0] + 30.0;
    int checked = 0, worstIndex = -1, normalMismatches = 0;
    double worst = 0.0;
    for (int i = 0; i < 20000; ++i) {
        Vec3f point;
        if (i % 4 == 3) { // on or just off a vertex, where neighbouring segments tie
            const auto& v = profile[std::size_t(unit(rng) * double(ns))];
            point = Vec3f(float(v[0]), float(v[1] + 1e-3 * step(rng)), 0.f);
        } else {
            point =
                Vec3f(float(x0 + (x1 - x0) * unit(rng)), float(-150.0 + 250.0 * unit(rng)), 0.f);
        }
        double distance = 0.0;
        Eigen::Vector3d normal;
        reference(point[0], point[1], distance, normal);
        const double error = std::abs(collider.signedDistance(point) - distance);
        if (error > worst) worst = error, worstIndex = i;
        if (std::abs(distance) > 0.01) { // the normal is defined off the surface
            const Vec3f n = collider.normal(point);
            if ((Eigen::Vector3d(n[0], n[1], 0.0) - normal).norm() > 1e-3) ++normalMismatches;
        }
        ++checked;
    }
    INFO(checked << " points, worst distance error " << worst << " m at point " << worstIndex
                 << ", " << normalMismatches << " normals off by more than 1e-3");
    REQUIRE(worst < 1e-4 + 1e-6 * 300.0);
    // Only a point equidistant from two segments to float rounding may take the other's normal.
    REQUIRE(normalMismatches <= 2);
}

TEST_CASE("a heightfield's one-lookup distance and normal are bitwise its two lookups'",
          "[collider]") {
    // A rough DEM (random heights), so that every cell has its own gradient; points inside it,
    // beyond its edges (clamped) and on its cell lines.
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> height(0.f, 30.f);
    std::vector<float> heights(12 * 9);
    for (float& h : heights) h = height(rng);
    TerrainDesc desc;
    desc.shape = TerrainShape::Heightfield;
    test::TempDir dir("firn-dem-rough");
    desc.file = dir.path() + "/rough.asc";
    {
        std::ofstream out(desc.file);
        out << "ncols 12\nnrows 9\nxllcorner -2.5\nyllcorner -2.5\ncellsize 5\n";
        out.precision(9);
        for (float h : heights) out << h << "\n";
    }
    const Collider ground = Collider::fromDesc(desc, 3);
    std::uniform_real_distribution<float> x(-10.f, 65.f), y(-5.f, 40.f), z(-10.f, 50.f);
    for (int k = 0; k < 20000; ++k) {
        const Vec3f p(k % 7 == 0 ? 5.f * float(k % 13) : x(rng), y(rng), z(rng));
        Collider::Slope slope;
        const float d = ground.signedDistance(p, slope);
        const float expected = ground.signedDistance(p);
        REQUIRE(std::memcmp(&d, &expected, sizeof d) == 0);
        const Vec3f n = ground.normal(p, slope);
        const Vec3f normal = ground.normal(p);
        REQUIRE(std::memcmp(n.data(), normal.data(), sizeof(float) * 3) == 0);
    }
    const Heightfield& dem = *ground.heightfield();
    for (int k = 0; k < 20000; ++k) {
        const float px = x(rng), pz = z(rng);
        float h = 0.f, hx = 0.f, hz = 0.f, gx = 0.f, gz = 0.f;
        dem.sampleAt(px, pz, h, hx, hz);
        dem.gradientAt(px, pz, gx, gz);
        const float expected = dem.heightAt(px, pz);
        REQUIRE(std::memcmp(&h, &expected, sizeof h) == 0);
        REQUIRE(std::memcmp(&hx, &gx, sizeof hx) == 0);
        REQUIRE(std::memcmp(&hz, &gz, sizeof hz) == 0);
    }
}
