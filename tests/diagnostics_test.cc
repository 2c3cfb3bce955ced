// Frame diagnostics: crack tracking and the stability watch, on synthetic frames.
#include "test_util.h"

#include <firn/diagnostics.h>
#include <firn/solver.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <tuple>

#include <catch2/catch.hpp>

using namespace firn;

namespace {

constexpr double kNoLayer = std::numeric_limits<double>::quiet_NaN(); // no uncracked layer left

/// A frame whose crack spans [minX, maxX] of a weak layer that has not cracked from intactMinX
/// to intactMaxX (by default far beyond both ends: the crack can grow either way).
FrameDiagnostics crackFrame(double minX, double maxX, double intactMinX = -1000.0,
                            double intactMaxX = 1000.0) {
    FrameDiagnostics d;
    d.hasWeakLayer = true;
    d.crackMinX = minX;
    d.crackMaxX = maxX;
    d.intactMinX = intactMinX;
    d.intactMaxX = intactMaxX;
    return d;
}

/// A 2D layer of one material on a flat plane, seeded on a regular lattice (dx 0.1).
std::string flatLayerScene(const std::string& model, double thickness, double length) {
    return "[simulation]\nname = \"layer\"\ndimension = 2\nend_time = 0.1\n"
           "[grid]\ndx = 0.1\nparticles_per_cell = 4\njitter = 0.0\n"
           "[[material]]\nname = \"snow\"\nmodel = \"" +
           model +
           "\"\n"
           "[[terrain]]\nshape = \"plane\"\npoint = [0.0, 0.0]\nnormal = [0.0, 1.0]\n"
           "[[body]]\nmaterial = \"snow\"\nshape = \"layer\"\nthickness = " +
           std::to_string(thickness) + "\nx_range = [0.0, " + std::to_string(length) + "]\n";
}

} // namespace

TEST_CASE("crack tracker follows the leading tip and fits a steady speed", "[diagnostics]") {
    CrackTracker crack;
    crack.update(FrameDiagnostics{}, 0.0); // no crack yet
    REQUIRE(std::isnan(crack.tip()));
    REQUIRE(crack.distance() == 0.0);
    // Onset at the cut tip (x = 1), then 30 m/s down-slope while the up-slope end creeps back
    // by 1 mm per frame, then arrival at the column's end (x = 4) where it stops.
    double t = 0.01;
    crack.update(crackFrame(1.0, 1.02), t);
    REQUIRE(crack.tip() == Approx(1.02));
    for (int k = 1; k <= 9; ++k) {
        t += 0.01;
        crack.update(crackFrame(1.0 - 0.001 * k, 1.02 + 0.3 * k), t);
        REQUIRE(crack.tip() == Approx(1.02 + 0.3 * k)); // the down-slope end leads
        REQUIRE(crack.speed() == Approx(30.0));
    }
    for (int k = 0; k < 5; ++k) crack.update(crackFrame(0.991, 4.0), t += 0.01);
    REQUIRE(crack.speed() == 0.0);
    REQUIRE(crack.maxSpeed() == Approx(30.0));
    REQUIRE(crack.meanSpeed() == Approx(30.0).epsilon(1e-6)); // the plateau is left out
    REQUIRE(crack.distance() == Approx((4.0 - 0.991) - 0.02));
}

TEST_CASE("crack tracker picks the up-slope tip when it leads", "[diagnostics]") {
    CrackTracker crack;
    crack.update(crackFrame(5.0, 5.1), 0.0);
    crack.update(crackFrame(4.5, 5.12), 0.01);
    REQUIRE(crack.tip() == Approx(4.5));
    REQUIRE(crack.speed() == Approx(50.0));
}

TEST_CASE("the stability watch flags energy growth and non-finite states", "[diagnostics]") {
    World world;
    world.dx = 0.1f;
    world.gravity = Vec3f(0.f, -10.f, 0.f);
    FrameDiagnostics first;
    first.mass = 2.0;
    first.kineticEnergy = 1.0;
    first.gravitationalEnergy = 100.0;
    const StabilityWatch watch(first, world);
    // Allowed gain: kinetic 1 + elastic 0 + m g dx 2 = 3 J, plus the potential energy released so
    // far (deliberately lenient: a blow-up gains orders of magnitude more).
    FrameDiagnostics d = first;
    d.gravitationalEnergy = 90.0; // fell: 10 J released
    d.kineticEnergy = 11.0;       // ... and turned into motion: fine
    REQUIRE(watch.check(d, world).empty());
    REQUIRE(watch.drift(d) == Approx(0.0));
    d.kineticEnergy = 11.0 + 13.5; // 13.5 J from nowhere: beyond the 3 + 10 J allowance
    REQUIRE_THAT(watch.check(d, world), Catch::Contains("energy grew by 13.5 J"));
    d.kineticEnergy = 11.0 + 12.9; // just inside it
    REQUIRE(watch.check(d, world).empty());
    d = first;
    d.finite = false;
    d.worstPosition = Eigen::Vector3d(1.0, 2.0, 3.0);
    world.time = 0.25;
    world.steps = 42;
    REQUIRE(watch.check(d, world) ==
            "non-finite particle state at t = 0.25 s, step 42, near x = (1, 2, 3) m");
}

TEST_CASE("crack tracker interpolates its tip in time and knows its direction", "[diagnostics]") {
    CrackTracker crack;
    REQUIRE(crack.direction() == 0);
    REQUIRE(std::isnan(crack.tipAt(0.0)));
    crack.update(crackFrame(5.0, 5.1), 0.1);
    crack.update(crackFrame(4.5, 5.12), 0.2); // runs up-slope
    crack.update(crackFrame(3.5, 5.12), 0.3);
    CHECK(crack.direction() == -1);
    CHECK(std::isnan(crack.tipAt(0.05)));    // before the crack
    CHECK(crack.tipAt(0.1) == Approx(5.1));  // first frame: the down-slope end
    CHECK(crack.tipAt(0.25) == Approx(4.0)); // halfway from 4.5 to 3.5
    CHECK(crack.tipAt(0.5) == Approx(3.5));  // after the last frame: the last tip
}

TEST_CASE("the crack tip is timed to the step from the cells' crack times", "[diagnostics]") {
    // Frames 0.02 s apart, cells of 0.1 m. The crack starts at x = 5.05 at 0.101 s and runs
    // up-slope, one cell per ms from 0.113 s, to x = 4.05 at 0.129 s, where it waits; a cell at
    // x = 3.55 cracked on its own at 0.105 s (4 cells beyond: more than kCrackGapCells), and the
    // crack reaches it at 0.138 s (x = 3.95): frames alone interpolate between 0.12 and 0.14 s.
    auto frame = [](const std::vector<std::pair<std::int64_t, float>>& cells) {
        FrameDiagnostics d = crackFrame((double(cells.front().first) + 0.5) * 0.1,
                                        (double(cells.back().first) + 0.5) * 0.1);
        d.crackCellWidth = 0.1;
        for (const auto& [cell, time] : cells)
            d.crackCells.push_back(cell), d.crackCellTimes.push_back(time);
        return d;
    };
    CrackTracker crack;
    std::vector<std::pair<std::int64_t, float>> cells{{49, 0.105f}, {50, 0.101f}, {51, 0.104f}};
    crack.update(frame(cells), 0.11);
    cells.insert(cells.begin(), {48, 0.113f});
    crack.update(frame(cells), 0.12);
    for (int c = 47; c >= 40; --c) cells.insert(cells.begin(), {c, 0.122f + 0.001f * (47 - c)});
    cells.insert(cells.begin(), {{35, 0.105f}, {39, 0.138f}});
    crack.update(frame(cells), 0.14);
    REQUIRE(crack.direction() == -1);
    CHECK(std::isnan(crack.tipAt(0.1)));
    CHECK(crack.tipAt(0.1015) == Approx(5.05));
    CHECK(crack.tipAt(0.1055) == Approx(4.95));
    CHECK(crack.tipAt(0.1255) == Approx(4.45));
    CHECK(crack.tipAt(0.137) == Approx(4.05));  // waiting: the cell ahead has not joined yet
    CHECK(crack.tipAt(0.1385) == Approx(3.55)); // 3.95 cracked, within reach of 3.55
    CHECK(crack.tipAt(1.0) == Approx(3.55));
    // The same frames without crack times: interpolated between frames.
    CrackTracker coarse;
    for (auto [t, lo] : {std::pair{0.11, 4.95}, {0.12, 4.85}, {0.14, 3.55}})
        coarse.update(crackFrame(lo, 5.15), t);
    CHECK(coarse.tipAt(0.13) == Approx(4.2));
}

TEST_CASE("the crack's arrival over the bed: each cell once, when its particles cracked, no "
          "earlier than the frame before, and cells holding only carried particles left out",
          "[diagnostics]") {
    // (cell (x, z), earliest and latest crack time of its cracked particles)
    using Plan = std::vector<std::pair<std::pair<std::int64_t, std::int64_t>, CellCrackTimes>>;
    auto frame = [](const Plan& cells) {
        FrameDiagnostics d;
        d.crackCellWidth = 0.1;
        for (const auto& [cell, times] : cells)
            d.crackPlanCells.push_back(cell), d.crackPlanCellTimes.push_back(times);
        return d;
    };
    CrackArrivalMap arrival;
    arrival.update(frame({}), 0.08);
    CHECK(arrival.cells().empty());
    arrival.update(frame({{{5, 2}, {0.095f, 0.099f}}, {{5, 3}, {0.099f, 0.099f}}}), 0.1);
    // The next frame, 0.02 s later: (5, 2) also holds a particle that cracked earlier elsewhere:
    // its time stays; (4, 2) and (5, 4) cracked since; (6, 0) holds a particle that cracked at
    // 0.05 s and one at 0.11 s: stamped at the frame before, 0.1 s; (7, 1) holds only particles
    // that cracked before 0.1 s, carried in: left out.
    arrival.update(frame({{{4, 2}, {0.113f, 0.113f}},
                          {{5, 2}, {0.09f, 0.118f}},
                          {{5, 3}, {0.099f, 0.099f}},
                          {{5, 4}, {0.117f, 0.119f}},
                          {{6, 0}, {0.05f, 0.11f}},
                          {{7, 1}, {0.05f, 0.099f}}}),
                   0.12);
    const std::vector<std::tuple<std::int64_t, std::int64_t, double>> expected{
        {4, 2, 0.113f}, {5, 2, 0.095f}, {5, 3, 0.099f}, {5, 4, 0.117f}, {6, 0, 0.1}};
    REQUIRE(arrival.cells().size() == expected.size());
    for (std::size_t k = 0; k < expected.size(); ++k) {
        const auto& [x, z, time] = expected[k];
        INFO("cell " << k);
        CHECK(arrival.cells()[k].x == x);
        CHECK(arrival.cells()[k].z == z);
        CHECK(arrival.cells()[k].time == time);
    }
    CHECK(arrival.cellWidth() == 0.1);
    // A checkpoint continues it exactly: a later frame stamps a new cell no earlier than 0.12 s.
    ByteWriter out;
    arrival.save(out);
    CrackArrivalMap resumed;
    ByteReader in(out.bytes().data(), out.bytes().size());
    resumed.load(in);
    resumed.update(frame({{{3, 2}, {0.11f, 0.13f}}}), 0.14);
    REQUIRE(resumed.cells().size() == 6);
    CHECK(resumed.cells().front().x == 3);
    CHECK(resumed.cells().front().time == 0.12);
}

TEST_CASE("slab_speed is the speed of the slab's centre of mass, the weak layer and a block do "
          "not count",
          "[diagnostics]") {
    const std::string text =
        "[simulation]\nname = \"slab\"\ndimension = 2\nend_time = 0.1\n"
        "[grid]\ndx = 0.1\nparticles_per_cell = 4\n"
        "[[material]]\nname = \"slab\"\nmodel = \"snow\"\n"
        "[[material]]\nname = \"weak\"\nmodel = \"weak_layer\"\n"
        "[[terrain]]\nshape = \"plane\"\npoint = [0.0, 0.0]\nnormal = [0.0, 1.0]\n"
        "[[body]]\nname = \"weak\"\nmaterial = \"weak\"\nshape = \"layer\"\nthickness = 0.2\n"
        "x_range = [0.0, 2.0]\n"
        "[[body]]\nname = \"slab\"\nmaterial = \"slab\"\nshape = \"layer\"\n"
        "on_top_of = \"weak\"\nthickness = 0.4\nx_range = [0.0, 2.0]\n"
        "[[material]]\nname = \"block\"\nmodel = \"snow\"\n"
        "[[body]]\nname = \"block\"\nmaterial = \"block\"\nshape = \"box\"\n"
        "min = [0.5, 1.0]\nmax = [1.0, 1.5]\n";
    auto world = buildWorld(test::sceneFromText(text), BuildStage::Seeded);
    ParticleSet& ps = world->particles;
    CHECK(computeDiagnostics(*world).slabSpeed() == 0.0); // seeded at rest
    // The slab's left half moves at (3, 4) m/s and its right half at rest: its centre of mass
    // at half of 5 m/s (equal masses). The weak layer and the block (a snow material of its own,
    // not a layer on a weak layer, as the slope scenes' triggers) move fast and do not count.
    for (std::size_t i = 0; i < ps.size(); ++i) {
        const Material& m = world->materials[ps.material[i]];
        const bool slab = m.slab;
        if (slab && ps.x[i][0] < 1.f) ps.v[i] = Vec3f(3.f, 4.f, 0.f);
        if (!slab) ps.v[i] = Vec3f(-20.f, 0.f, 0.f);
    }
    CHECK(computeDiagnostics(*world).slabSpeed() == Approx(2.5).epsilon(1e-5));
}

TEST_CASE("the crack and the collapse behind it are the largest runs of their weak-layer cells, "
          "not a stray particle",
          "[diagnostics]") {
    auto world =
        buildWorld(test::sceneFromText(flatLayerScene("weak_layer", 0.1, 5.0)), BuildStage::Seeded);
    ParticleSet& ps = world->particles;
    REQUIRE(std::isnan(computeDiagnostics(*world).crackMinX)); // nothing has failed
    REQUIRE(std::isnan(computeDiagnostics(*world).collapseMinX));
    // The uncracked layer: all of it (particles on the lattice at x 0.025 ... 4.975 m).
    CHECK(computeDiagnostics(*world).intactMinX == Approx(0.025));
    CHECK(computeDiagnostics(*world).intactMaxX == Approx(4.975));
    // A crack over x in [1, 2] m, a gap of 3 cells bridged inside it ([1.5, 1.8] intact), and
    // one stray particle at x > 4.5 (more than kCrackGapCells away). Its softening has finished
    // (p0 reached 0: the collapse flag) over [1.8, 2] only, and in the stray particle.
    bool stray = false;
    for (std::size_t i = 0; i < ps.size(); ++i) {
        const float x = ps.x[i][0];
        if ((x > 1.f && x < 1.5f) || (x > 1.8f && x < 2.f)) ps.plastic[i].eta = 0.1f;
        if (x > 1.8f && x < 2.f) ps.plastic[i].flags |= kFlagCollapsed;
        if (x > 4.5f && !stray) {
            ps.plastic[i].eta = 0.1f, stray = true;
            ps.plastic[i].flags |= kFlagCollapsed;
        }
    }
    const FrameDiagnostics d = computeDiagnostics(*world);
    CHECK(d.crackMinX == Approx(1.05)); // cell centres
    CHECK(d.crackMaxX == Approx(1.95));
    CHECK(d.collapseMinX == Approx(1.85)); // the process zone: 0.8 m up-slope of it
    CHECK(d.collapseMaxX == Approx(1.95));
    CHECK(d.intactMinX == Approx(0.025)); // uncracked layer remains beyond both ends
    CHECK(d.intactMaxX == Approx(4.975));
    // Cracked up-slope of 1 m too: the uncracked layer starts in the bridged gap at 1.5 m.
    for (std::size_t i = 0; i < ps.size(); ++i)
        if (ps.x[i][0] < 1.f) ps.plastic[i].eta = 0.1f;
    CHECK(computeDiagnostics(*world).intactMinX == Approx(1.525));
}

TEST_CASE("crack tracker restarts at a new, larger crack that does not overlap the old one",
          "[diagnostics]") {
    CrackTracker crack;
    crack.update(crackFrame(4.6, 4.65), 0.0); // a few particles yielded under the static load
    crack.update(crackFrame(4.6, 4.65), 0.1);
    crack.update(crackFrame(12.5, 13.5), 0.2); // the trigger's crack
    crack.update(crackFrame(10.5, 14.0), 0.22);
    REQUIRE(crack.direction() == -1); // up-slope: from the trigger, not from the stray
    REQUIRE(crack.tip() == Approx(10.5));
    REQUIRE(crack.speed() == Approx(100.0));
    REQUIRE(std::isnan(crack.tipAt(0.1))); // before the new crack
    REQUIRE(crack.distance() == Approx(2.5));
}

TEST_CASE("runout and alpha angle measure the snow that moved, not a base that never did",
          "[diagnostics]") {
    // A 10 m layer of which only x < 2 m has moved: the deposit's tip is at 2 m, not 10 m.
    auto world =
        buildWorld(test::sceneFromText(flatLayerScene("elastic", 0.2, 10.0)), BuildStage::Seeded);
    ParticleSet& ps = world->particles;
    REQUIRE(std::isnan(computeDiagnostics(*world).movedFarX)); // nothing moved
    for (std::size_t i = 0; i < ps.size(); ++i)
        if (ps.x[i][0] < 2.f) ps.plastic[i].flags |= kFlagMoved;
    const FrameDiagnostics d = computeDiagnostics(*world);
    CHECK(d.movedFarX == Approx(1.975)); // the last particle column before x = 2 m
    CHECK(d.movedTopY == Approx(0.175));
    // 1 m of drop over 1 m of run: 45 degrees; a deposit not beyond the top: undefined.
    CHECK(alphaAngleDeg(0.0, 1.0, 1.0, 0.0) == Approx(45.0));
    CHECK(std::isnan(alphaAngleDeg(2.0, 1.0, 1.0, 0.0)));
}

TEST_CASE("crack tracker: the end that propagated leads, not one carried by flowing snow",
          "[diagnostics]") {
    CrackTracker crack;
    // The trigger's crack at x = 12-13 m runs up-slope at 100 m/s to x = 5 m and down to 17 m
    // at 80 m/s, over frames 0.02 s apart ...
    crack.update(crackFrame(12.0, 13.0), 0.20);
    crack.update(crackFrame(10.0, 14.6), 0.22);
    crack.update(crackFrame(8.0, 16.2), 0.24);
    crack.update(crackFrame(6.0, 17.0), 0.26);
    crack.update(crackFrame(5.0, 17.0), 0.28);
    CHECK(crack.direction() == -1);
    // ... then the released slab flows down-slope at 5 m/s for 2 s, carrying failed weak layer
    // with it: the down-slope end grows 10 m more (14 m in all, against the up-slope end's 7 m),
    // but slower than a crack runs.
    double t = 0.28;
    for (int k = 1; k <= 100; ++k) crack.update(crackFrame(5.0, 17.0 + 0.1 * k), t += 0.02);
    CHECK(crack.direction() == -1);
    CHECK(crack.tip() == Approx(5.0));
    // Up-slope travel 7 m: 10 % (11.3 m) passed at 0.207 s, 90 % (5.7 m) at 0.266 s.
    CHECK(crack.meanSpeed() == Approx(0.8 * 7.0 / (0.266 - 0.207)).epsilon(1e-9));
}

TEST_CASE("crack tracker: the mean speed ends where the crack stopped, not where flow carried it",
          "[diagnostics]") {
    CrackTracker crack;
    // A crack runs down-slope at 50 m/s from x = 9 to 18 m (the weak layer's end) ...
    crack.update(crackFrame(8.0, 9.0), 0.36);
    for (int k = 1; k <= 9; ++k) crack.update(crackFrame(8.0, 9.0 + 1.0 * k), 0.36 + 0.02 * k);
    CHECK(crack.direction() == 1);
    // ... then the sliding slab carries the failed layer on at 2.5 m/s for 1 s.
    double t = 0.54;
    for (int k = 1; k <= 25; ++k) crack.update(crackFrame(8.0, 18.0 + 0.1 * k), t += 0.04);
    CHECK(crack.tip() == Approx(20.5));
    // The travel is the crack's 9 m, not 11.5: 10 % passed at 0.378 s, 90 % at 0.522 s.
    CHECK(crack.meanSpeed() == Approx(0.8 * 9.0 / (0.522 - 0.378)).epsilon(1e-9)); // 50 m/s
}

TEST_CASE("crack tracker: failed layer carried past the layer's end at crack speed is not the "
          "crack",
          "[diagnostics]") {
    // scenes/slope2d.toml's layer over x 0.5-20 m: the crack from the snowman (12-13 m) runs
    // up-slope to the top at 100 m/s and down to the layer's end at 20 m at 70 m/s, over frames
    // 0.02 s apart; the uncracked layer lies beyond both ends until they reach the layer's ends.
    CrackTracker crack;
    double t = 0.0;
    crack.update(crackFrame(12.0, 13.0, 0.5, 20.0), t);
    for (int k = 1; k <= 6; ++k) {
        const double up = std::max(12.0 - 2.0 * k, 0.5), down = std::min(13.0 + 1.4 * k, 20.0);
        // Uncracked: [0.5, up] and [down, 20], where they are left.
        const double intactMin = up > 0.5 ? 0.5 : down < 20.0 ? down : kNoLayer;
        const double intactMax = down < 20.0 ? 20.0 : up > 0.5 ? up : kNoLayer;
        crack.update(crackFrame(up, down, intactMin, intactMax), t += 0.02);
    }
    REQUIRE(crack.direction() == -1);
    const double grown = crack.distance();
    CHECK(grown == Approx((20.0 - 0.5) - 1.0));
    const double steady = crack.meanSpeed();
    CHECK(steady == Approx(100.0).epsilon(0.02));
    // The avalanche then carries the failed layer past the end: the extent's far end jumps
    // 0.25 m in some frames (12.5 m/s) and rests in others, 7.5 m in all, more than the 6 m that
    // the crack ran up-slope from where the down-slope end was then. Only uncracked layer up-slope
    // of the crack (none) and down-slope (none) could be cracked.
    double carried = 20.0;
    for (int k = 1; k <= 60; ++k) {
        carried += k % 2 ? 0.25 : 0.0;
        crack.update(crackFrame(0.5, carried, kNoLayer, kNoLayer), t += 0.02);
    }
    CHECK(crack.direction() == -1);
    CHECK(crack.tip() == Approx(0.5));
    CHECK(crack.distance() == Approx(grown)); // each end as far as it grew
    CHECK(crack.meanSpeed() == Approx(steady));
    CHECK(crack.distanceBehind(19.0, t) == Approx(20.0 - 19.0)); // from the layer's end
}

TEST_CASE("crack tracker: a mean speed from a crack that crossed the column in two frames",
          "[diagnostics]") {
    CrackTracker crack;
    crack.update(crackFrame(2.9, 3.0), 0.0);
    crack.update(crackFrame(1.4, 3.0), 0.02); // 75 m/s
    crack.update(crackFrame(0.0, 3.0), 0.04); // 70 m/s
    crack.update(crackFrame(0.0, 3.0), 0.06);
    // travel 2.9 m: 10 % at 0.02 * 0.29 / 1.5, 90 % at 0.02 + 0.02 * (2.61 - 1.5) / 1.4
    const double t10 = 0.02 * 0.29 / 1.5, t90 = 0.02 + 0.02 * 1.11 / 1.4;
    CHECK(crack.meanSpeed() == Approx(0.8 * 2.9 / (t90 - t10)).epsilon(1e-9));
}
