// Seeding from bodies: layers draped on terrain, saw cuts, thickness noise, overlap.
#include "test_util.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <map>

using namespace firn;

namespace {

std::string layerScene(const std::string& extraLayerKeys, const std::string& extra = "") {
    return "[simulation]\nname = \"layers\"\ndimension = 2\nend_time = 1.0\n"
           "[grid]\ndx = 0.05\nparticles_per_cell = 4\n"
           "[[material]]\nname = \"snow\"\nmodel = \"elastic\"\n"
           "[[terrain]]\nshape = \"plane\"\npoint = [0.0, 0.0]\nnormal = [0.5, 0.8660254]\n"
           "[[body]]\nname = \"weak\"\nmaterial = \"snow\"\nshape = \"layer\"\nthickness = 0.1\n"
           "x_range = [0.0, 40.0]\n"
           "[[body]]\nname = \"slab\"\nmaterial = \"snow\"\nshape = \"layer\"\non_top_of = "
           "\"weak\"\n"
           "thickness = 0.5\nx_range = [0.0, 40.0]\n" +
           extraLayerKeys + extra;
}

/// Distance of a point above the 30 degree plane through the origin.
double aboveSlope(const Vec3f& p) {
    return 0.5 * p[0] + 0.8660254 * p[1];
}

} // namespace

TEST_CASE("layers are draped normal to the terrain and stacked", "[setup]") {
    // As seeded (settling moves the particles by the layers' elastic compression).
    auto world = buildWorld(test::sceneFromText(layerScene("")), BuildStage::Seeded);
    const ParticleSet& ps = world->particles;
    REQUIRE(world->particlesPerBody.size() == 2);
    double lo[2] = {1e9, 1e9}, hi[2] = {-1e9, -1e9};
    for (std::size_t i = 0; i < ps.size(); ++i) {
        // one material for both: tell the layers apart by height above the slope
        const double d = aboveSlope(ps.x[i]);
        const int layer = d < 0.1 ? 0 : 1;
        lo[layer] = std::min(lo[layer], d), hi[layer] = std::max(hi[layer], d);
    }
    // Seeds sit inside their layer; with 2 x 2 seeds per 5 cm cell the outermost lie within
    // half a sub-cell (1.25 cm) plus the jitter of the faces.
    REQUIRE(lo[0] >= 0.0);
    REQUIRE(lo[0] < 0.02);
    REQUIRE(hi[0] < 0.1);
    REQUIRE(lo[1] >= 0.1);
    REQUIRE(hi[1] < 0.6);
    REQUIRE(hi[1] > 0.58);
    // Particle counts follow the areas: 40 m x 0.1 m and 40 m x 0.5 m at 4 / (0.05 m)^2
    // (the x range is horizontal, the thickness normal: area = 40 m * t / cos 30).
    const double perArea = 4.0 / (0.05 * 0.05);
    REQUIRE(double(world->particlesPerBody[0]) ==
            Approx(40.0 * 0.1 / 0.8660254 * perArea).epsilon(0.02));
    REQUIRE(double(world->particlesPerBody[1]) ==
            Approx(40.0 * 0.5 / 0.8660254 * perArea).epsilon(0.02));
}

TEST_CASE("a saw cut removes the weak layer over its length only", "[setup]") {
    auto world = buildWorld(test::sceneFromText(layerScene(
                                "", "[[cut]]\nlayer = \"weak\"\nfrom_x = 10.0\nlength = 2.5\n")),
                            BuildStage::Seeded);
    const ParticleSet& ps = world->particles;
    std::size_t weakInCut = 0, slabInCut = 0;
    for (std::size_t i = 0; i < ps.size(); ++i) {
        const bool inCut = ps.x[i][0] >= 10.0f && ps.x[i][0] < 12.5f;
        if (!inCut) continue;
        (aboveSlope(ps.x[i]) < 0.1 ? weakInCut : slabInCut)++;
    }
    REQUIRE(weakInCut == 0);
    REQUIRE(slabInCut > 1000); // the slab above the cut is still there
}

TEST_CASE("both saws leave the same snow at t = 0 when the scene does not settle", "[setup]") {
    // Without the settling stage (seconds of it on 40 m of layers) the two saws are the same
    // cut: the quasi-static one never seeds the cut, the instant one seeds it and removes it
    // at t = 0. (What settling changes, the overhang's load, is in the PST tests.)
    auto scene = [](const std::string& saw) {
        std::string text =
            layerScene("", "[[cut]]\nlayer = \"weak\"\nfrom_x = 10.0\nlength = 2.5\n" + saw);
        text.insert(text.find("end_time"), "settle = false\n");
        return test::sceneFromText(text);
    };
    const auto quasiStatic = buildWorld(scene(""));
    const auto instant = buildWorld(scene("saw = \"instant\"\n"));
    REQUIRE(quasiStatic->particles.size() == instant->particles.size());
    for (std::size_t i = 0; i < instant->particles.size(); ++i)
        REQUIRE(quasiStatic->particles.x[i] == instant->particles.x[i]);
    CHECK(quasiStatic->particlesPerBody == instant->particlesPerBody);
}

TEST_CASE("thickness noise has the asked spread and is set by the seed", "[setup]") {
    const std::string noisy = "thickness_noise = { std = 0.25, correlation_length = 2.0 }\n";
    // Put the noise on the slab: insert the key into the second body.
    std::string text = layerScene("");
    text.insert(text.find("thickness = 0.5\n") + 16, noisy);
    auto world = buildWorld(test::sceneFromText(text));
    const ParticleSet& ps = world->particles;
    // Slab thickness per 0.5 m strip of x: the highest particle above the slope minus 0.1 m.
    std::map<int, double> top;
    for (std::size_t i = 0; i < ps.size(); ++i) {
        const int strip = int(std::floor(ps.x[i][0] / 0.5f));
        top[strip] = std::max(top.count(strip) ? top[strip] : 0.0, aboveSlope(ps.x[i]));
    }
    double sum = 0, sumSq = 0;
    for (const auto& [strip, t] : top) sum += t - 0.1, sumSq += (t - 0.1) * (t - 0.1);
    const double n = double(top.size());
    const double mean = sum / n, sd = std::sqrt(sumSq / n - mean * mean);
    INFO("slab thickness: mean " << mean << " m, std " << sd / mean << " of the mean");
    // 40 m is 20 correlation lengths: the sample std of a unit field scatters by ~1/sqrt(20)
    // around 1, so accept 0.25 +- 40 %; the mean stays near 0.5 m.
    REQUIRE(mean == Approx(0.5).epsilon(0.15));
    REQUIRE(sd / mean > 0.15);
    REQUIRE(sd / mean < 0.35);
    // Same seed, same layer; another seed, another layer.
    auto again = buildWorld(test::sceneFromText(text));
    REQUIRE(again->particles.size() == ps.size());
    std::string reseeded = text;
    reseeded.insert(reseeded.find("end_time"), "seed = 7\n");
    REQUIRE(buildWorld(test::sceneFromText(reseeded))->particles.size() != ps.size());
}

TEST_CASE("a thickness profile sets the layer's thickness along x", "[setup]") {
    // The slab 0.3 m at x = 0, 0.7 m at x = 20, 0.3 m from x = 40 on (deepest mid-path).
    std::string text = layerScene("");
    text.replace(text.find("thickness = 0.5\n"), 16,
                 "thickness_profile = [[0.0, 0.3], [20.0, 0.7], [40.0, 0.3]]\n");
    auto world = buildWorld(test::sceneFromText(text), BuildStage::Seeded);
    const ParticleSet& ps = world->particles;
    // Slab thickness per 1 m strip of x: the highest particle above the slope minus the weak
    // layer's 0.1 m (the seeds' top lies within a quarter cell, 1.25 cm, of the surface).
    std::map<int, double> top;
    for (std::size_t i = 0; i < ps.size(); ++i) {
        const int strip = int(std::floor(ps.x[i][0]));
        top[strip] = std::max(top.count(strip) ? top[strip] : 0.0, aboveSlope(ps.x[i]));
    }
    auto profile = [](double x) { return x < 20.0 ? 0.3 + 0.02 * x : 0.7 - 0.02 * (x - 20.0); };
    for (const int strip : {2, 10, 19, 30, 37}) {
        INFO("strip x = " << strip << " m");
        // The strip's highest seed sits under the surface at the strip's thicker end: allow one
        // strip's change (0.02 m) plus the quarter cell.
        const double thick = std::max(profile(strip), profile(strip + 1));
        CHECK(top[strip] - 0.1 == Approx(thick).margin(0.035));
    }
}

TEST_CASE("a body that seeds nothing or lies inside the terrain is a scene error", "[setup]") {
    const std::string ball = "[[material]]\nname = \"ice\"\nmodel = \"elastic\"\n"
                             "[[body]]\nname = \"ball\"\nmaterial = \"ice\"\nshape = \"sphere\"\n";
    auto errorOf = [&](const std::string& where) {
        try {
            buildWorld(test::sceneFromText(layerScene("", ball + where)), BuildStage::Seeded);
        } catch (const SceneError& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    CHECK(errorOf("center = [10.0, 3.0]\nradius = 0.5\n") == "no error");
    // The 30 degree plane through the origin: (10, -8) is 3.9 m below the ground.
    CHECK(errorOf("center = [10.0, -8.0]\nradius = 0.5\n")
              .find("error: body \"ball\": lies entirely inside the terrain: all its ") !=
          std::string::npos);
    CHECK(errorOf("center = [10.0, 3.0]\nradius = 0.001\n")
              .find("error: body \"ball\": seeds no particles at dx = 0.05 m") !=
          std::string::npos);
}

TEST_CASE("the particle estimate matches seeding without seeding", "[setup]") {
    // Layers on a 30 degree slope, a box and a sphere (overlapping the layers: the overlap is
    // counted once, as seeding does). Seeding's cells sample each body exactly; the estimate's
    // coarser lattice (at most 2e5 points a body) is within a few percent for bodies many cells
    // across: 3 % allows for the faces' half cells over the thinnest layer (0.1 m = 2 cells).
    const std::string extra = "[[material]]\nname = \"ice\"\nmodel = \"elastic\"\n"
                              "[[body]]\nmaterial = \"ice\"\nshape = \"box\"\n"
                              "min = [5.0, -2.0]\nmax = [7.0, 1.0]\n"
                              "[[body]]\nmaterial = \"ice\"\nshape = \"sphere\"\n"
                              "center = [20.0, -5.0]\nradius = 1.5\n";
    const SceneDesc scene = test::sceneFromText(layerScene("", extra));
    const std::vector<double> estimate = estimateParticlesPerBody(scene);
    auto world = buildWorld(scene, BuildStage::Seeded);
    REQUIRE(estimate.size() == 4);
    for (std::size_t b = 0; b < 4; ++b) {
        INFO("body " << b + 1);
        CHECK(estimate[b] == Approx(double(world->particlesPerBody[b])).epsilon(0.03));
    }
    // At a spacing that would seed 2.6e9 particles, the estimate still comes (a lattice of
    // ~2e5 points per body) and scales as dx^-2.
    SceneDesc fine = scene;
    fine.grid.dx = 0.0005;
    const std::vector<double> fineEstimate = estimateParticlesPerBody(fine);
    CHECK(fineEstimate[1] == Approx(estimate[1] * 1e4).epsilon(0.03));
}

TEST_CASE("the world's weak layer gets the crack band's softening at the scene's dx", "[setup]") {
    // softening_length from the table (0.06 m): at dx 0.0075 the 6-cell band is 0.045 m, so
    // alpha 100 becomes 75; at dx 0.01 the band is the layer's 0.06 m and alpha stays.
    auto text = [](const std::string& dx) {
        return "[simulation]\nname = \"band\"\ndimension = 2\nend_time = 1.0\n"
               "[grid]\ndx = " +
               dx +
               "\n"
               "[[material]]\nname = \"weak\"\nmodel = \"weak_layer\"\nsoftening = 100\n";
    };
    CHECK(buildWorld(test::sceneFromText(text("0.0075")), BuildStage::Bare)
              ->materials[0]
              .camClay.alpha == 75.f);
    CHECK(buildWorld(test::sceneFromText(text("0.01")), BuildStage::Bare)
              ->materials[0]
              .camClay.alpha == 100.f);
}
