// firn report's C++ side: weak-layer binning, the choice of map frames and the snow depth along
// the path, on synthetic data.
#include "report/deposit_profile.h"
#include "report/map_frames.h"
#include "report/run_scene.h"
#include "report/weak_layer_map.h"
#include "test_util.h"

#include <firn/errors.h>

#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>
#include <limits>

using namespace firn;
using namespace firn::report;

namespace {

constexpr std::int32_t kSlab = 0, kWeak = 1;
// The weak layer's initial surface: p0 3450 Pa, M 1, beta 0.1 (scenes/pst.toml's layer).
const std::vector<WeakLayerMaterial> kIsWeakLayer = {{}, {true, 3450.0, 1.0, 0.1}};
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

void addParticle(ParticleFrame& f, std::array<float, 3> P, std::int32_t material,
                 std::array<float, 3> v = {0, 0, 0}, bool failed = false, float eta = 0,
                 float p = 0, float q = 0) {
    f.P.push_back(P);
    f.v.push_back(v);
    f.material.push_back(material);
    f.failed.push_back(failed ? 1 : 0);
    f.eps_v.push_back(0);
    f.eta.push_back(eta);
    f.p.push_back(p);
    f.q.push_back(q);
}

} // namespace

TEST_CASE("2D weak-layer cells: failed share, means, and the slab speed, failed share and p above",
          "[report]") {
    ParticleFrame f;
    // Cell 0 (x in [0, 0.1)): one failed and one elastic weak-layer particle under a slab
    // particle moving at 5 m/s.
    addParticle(f, {0.02f, 0.01f, 0}, kWeak, {}, true, 0.2f, 1000);
    addParticle(f, {0.07f, 0.02f, 0}, kWeak, {}, false, 0.0f, 3000);
    addParticle(f, {0.05f, 0.30f, 0}, kSlab, {3, 4, 0}, false, 0, 800);
    // A yielded, resting base particle below the weak layer: not slab, counted in neither mean.
    addParticle(f, {0.05f, -0.10f, 0}, kSlab, {}, true, 0, 9000);
    // Cell 1: failed weak layer, two slab particles at 1 and 3 m/s, one in tension (p < 0).
    addParticle(f, {0.15f, 0.01f, 0}, kWeak, {}, true, 0.4f, 500);
    addParticle(f, {0.12f, 0.30f, 0}, kSlab, {1, 0, 0}, false, 0, -3000);
    addParticle(f, {0.18f, 0.40f, 0}, kSlab, {0, -3, 0}, true, 0, 1000);
    // Cell 2: slab only (a saw cut): no row. Cell -1: weak layer without slab above.
    addParticle(f, {0.25f, 0.30f, 0}, kSlab, {9, 0, 0});
    addParticle(f, {-0.05f, 0.01f, 0}, kWeak, {}, false, 0.0f, 200);

    const auto cells = binWeakLayer(f, kIsWeakLayer, 0.1, 2);
    REQUIRE(cells.size() == 3);
    CHECK(cells[0].x == Approx(-0.05)); // floor, not truncation towards zero
    CHECK(std::isnan(cells[0].slabSpeed));
    CHECK(cells[1].x == Approx(0.05));
    CHECK(cells[1].z == 0.0);
    CHECK(cells[1].particles == 2);
    CHECK(cells[1].failedFraction == Approx(0.5));
    CHECK(cells[1].eta == Approx(0.1));
    CHECK(cells[1].p == Approx(2000));
    CHECK(cells[1].slabSpeed == Approx(5));
    CHECK(cells[1].slabFailedFraction == 0.0);
    CHECK(cells[1].slabP == Approx(800)); // the base's 9000 Pa below the layer is not slab
    CHECK(std::isnan(cells[0].slabFailedFraction));
    CHECK(std::isnan(cells[0].slabP));
    CHECK(cells[2].x == Approx(0.15));
    CHECK(cells[2].failedFraction == 1.0);
    CHECK(cells[2].slabSpeed == Approx(2));
    CHECK(cells[2].slabFailedFraction == Approx(0.5));
    CHECK(cells[2].slabP == Approx(-1000));
}

TEST_CASE("weak-layer cells: the mean share of the initial strength the stress uses", "[report]") {
    ParticleFrame f;
    // On the surface at the ellipse's top (p = p_c = 0.45 p0, q = M (1 + beta) p0 / (2 sqrt(1 + 2
    // beta))): 1; half of that stress: 0.5; a slab particle at the same place does not count.
    const float p0 = 3450.f, pTop = 0.45f * p0;
    const float qTop = 1.1f * p0 / (2.f * std::sqrt(1.2f));
    addParticle(f, {0.02f, 0.01f, 0}, kWeak, {}, false, 0, pTop, qTop);
    addParticle(f, {0.07f, 0.02f, 0}, kWeak, {}, false, 0, 0.5f * pTop, 0.5f * qTop);
    addParticle(f, {0.05f, 0.30f, 0}, kSlab, {}, false, 0, 10 * pTop, 10 * qTop);
    const auto cells = binWeakLayer(f, kIsWeakLayer, 0.1, 2);
    REQUIRE(cells.size() == 1);
    CHECK(cells[0].strengthUsed == Approx(0.75).epsilon(1e-5));
}

TEST_CASE("3D weak-layer cells form an x-z raster in z-then-x order", "[report]") {
    ParticleFrame f;
    addParticle(f, {0.15f, 0.0f, 0.25f}, kWeak, {}, true);
    addParticle(f, {0.05f, 0.0f, 0.25f}, kWeak);
    addParticle(f, {0.15f, 0.0f, 0.05f}, kWeak);
    addParticle(f, {0.15f, 0.5f, 0.05f}, kSlab, {0, 0, 2});
    const auto cells = binWeakLayer(f, kIsWeakLayer, 0.1, 3);
    REQUIRE(cells.size() == 3);
    CHECK(cells[0].z == Approx(0.05));
    CHECK(cells[0].slabSpeed == Approx(2));
    CHECK(cells[1].z == Approx(0.25));
    CHECK(cells[1].x == Approx(0.05));
    CHECK(cells[2].x == Approx(0.15));
    CHECK(cells[2].failedFraction == 1.0);
}

TEST_CASE("snow depth along x: the particles' seeded volume per metre along x and of the width "
          "holding snow",
          "[report]") {
    // dx 0.1, 4 particles per cell. 2D: a 0.3 m layer (3 cells x 4 particles) over x 1.0-1.1 and
    // one particle at x 1.25: depth = particles * dx^2 / 4 / dx.
    ParticleFrame flat;
    for (int k = 0; k < 12; ++k) addParticle(flat, {1.05f, 0.025f * float(k), 0.f}, kSlab);
    addParticle(flat, {1.25f, 0.5f, 0.f}, kWeak);
    auto cells = snowDepthAlongX(flat, 0.1, 2, 4);
    REQUIRE(cells.size() == 2);
    CHECK(cells[0].x == Approx(1.05));
    CHECK(cells[0].depth == Approx(0.3));
    CHECK(cells[1].x == Approx(1.25));
    CHECK(cells[1].depth == Approx(0.025));
    // 3D, 8 particles per cell: a 0.2 m deep column two z cells wide (4 cells of 8) at x 2.0-2.1
    // reads 0.2 m, not twice that: the depth is per metre of the width holding snow.
    ParticleFrame wide;
    for (int k = 0; k < 32; ++k)
        addParticle(wide, {2.05f, 0.0125f * float(k % 16), k < 16 ? 0.05f : 0.15f}, kSlab);
    cells = snowDepthAlongX(wide, 0.1, 3, 8);
    REQUIRE(cells.size() == 1);
    CHECK(cells[0].depth == Approx(0.2));
}

TEST_CASE("map frames: evenly spaced while the crack runs, or at requested times", "[report]") {
    const std::vector<int> frames = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10};
    std::vector<double> times;
    for (int f : frames) times.push_back(0.01 * f);
    // The crack appears at frame 2 and reaches its end (x = 3) at frame 8.
    const std::vector<double> tip = {kNaN, kNaN, 1.0, 1.3, 1.7, 2.0, 2.4, 2.8, 3.0, 3.0, 3.0};
    CHECK(chooseMapFrames(frames, times, tip, {}, 0.02) == std::vector<int>{2, 4, 6, 8});

    SECTION("no crack: over the whole run") {
        const std::vector<double> none(frames.size(), kNaN);
        CHECK(chooseMapFrames(frames, times, none, {}, 0.02) == std::vector<int>{0, 3, 7, 10});
    }
    SECTION("requested times go to the nearest frame, sorted, each once") {
        CHECK(chooseMapFrames(frames, times, tip, {0.052, 0.011, 0.013, 0.104}, 0.02) ==
              std::vector<int>{1, 5, 10});
    }
    SECTION("a time outside the run names --times") {
        REQUIRE_THROWS_AS(chooseMapFrames(frames, times, tip, {0.5}, 0.02), SceneError);
        REQUIRE_THROWS_WITH(chooseMapFrames(frames, times, tip, {0.5}, 0.02),
                            Catch::Contains("--times") && Catch::Contains("outside the run"));
    }
}

TEST_CASE("The report reads a hazard run's scene without its DEM, release or path line files",
          "[report]") {
    // A run folder moved to another machine: scene.toml names files that are gone. The report
    // needs none of them (a path line once stopped it: "the scene has no heightfield terrain").
    const test::TempDir folder("report-run-scene");
    const std::string path = folder.path() + "/scene.toml";
    std::ofstream(path) << "[output]\npath = \"/nowhere/path.geojson\"\nrasters = true\n"
                           "runout_pressure = 2.0\n\n[simulation]\ndimension = 3\n"
                           "name = \"helix\"\n\n[[body]]\nfile = \"/nowhere/release.geojson\"\n"
                           "material = \"snow\"\nshape = \"polygon\"\n\n[[material]]\n"
                           "model = \"granular\"\nname = \"snow\"\n\n[[terrain]]\n"
                           "file = \"/nowhere/dem.asc\"\nshape = \"heightfield\"\n";
    const SceneDesc scene = loadRunScene(path);
    CHECK(scene.simulation.dimension == 3);
    CHECK(scene.simulation.name == "helix");
    REQUIRE(scene.materials.size() == 1);
    CHECK(scene.materials[0].name == "snow");
    CHECK(scene.terrains.empty());
    CHECK(scene.output.path.empty());
    CHECK(scene.output.runoutPressure == 2.0);
}
