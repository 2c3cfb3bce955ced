// Slab fractures and blocks: the detector on synthetic slabs, then a slab pulled apart in
// tension end to end.
#include "test_util.h"

#include <firn/io.h>
#include <firn/run.h>
#include <firn/slab_fracture.h>

#include <catch2/catch.hpp>
#include <tbb/global_control.h>

#include <algorithm>
#include <fstream>
#include <functional>
#include <random>

using namespace firn;

namespace {

constexpr double kDx = 0.05;
constexpr double kSpacing = 0.025; // 2 x 2 particles per cell

/// A 2D slab from x = 0 to `length` and from 0.1 m (the weak-layer interface) to 0.5 m above a
/// flat bed, 1 kg per particle; particle (i, j) sits at ((i + 1/2), (j + 1/2)) * 2.5 cm + 0.1 m.
/// `fractureTime(i, j)` < 0: intact.
std::vector<SlabSample> flatSlab(double length, const std::function<double(int, int)>& fractureTime,
                                 int columnsZ = 1) {
    std::vector<SlabSample> samples;
    const int nx = int(std::lround(length / kSpacing)), ny = 16;
    for (int k = 0; k < columnsZ; ++k)
        for (int i = 0; i < nx; ++i)
            for (int j = 0; j < ny; ++j) {
                SlabSample s;
                const float x = float((i + 0.5) * kSpacing), y = float(0.1 + (j + 0.5) * kSpacing);
                const float z = columnsZ > 1 ? float((k + 0.5) * kSpacing) : 0.f;
                s.position = Vec3f(x, y, z);
                s.bedX = x, s.bedZ = z, s.height = y;
                s.mass = 1.f;
                const double t = fractureTime(i, j);
                s.fractured = t >= 0.0;
                s.fractureTime = s.fractured ? float(t) : 0.f;
                samples.push_back(s);
            }
    return samples;
}

/// A crack tracker whose tip runs down-slope from x = 1.5 at t = 0 to 3.5 at t = 0.2.
CrackTracker runningCrack() {
    CrackTracker crack;
    FrameDiagnostics d;
    d.hasWeakLayer = true;
    d.intactMinX = 0.0, d.intactMaxX = 4.0; // the layer beyond both ends
    d.crackMinX = 1.4, d.crackMaxX = 1.5;
    crack.update(d, 0.0);
    d.crackMaxX = 3.5;
    crack.update(d, 0.2);
    return crack;
}

} // namespace

TEST_CASE("a fracture through the slab is found at its bin, time and start depth",
          "[slab_fracture]") {
    // Columns 40 and 41 (x in [1.0, 1.05), bin 20) fracture row by row, 1 ms apart per particle.
    SECTION("from the bottom (the weak-layer interface)") {
        const auto samples =
            flatSlab(2.0, [](int i, int j) { return i == 40 || i == 41 ? 0.1 + 0.001 * j : -1.0; });
        const auto bins = findThroughBins(samples, kDx, 2);
        REQUIRE(bins.size() == 1);
        CHECK(bins[0].ix == 20);
        // 8 rows of 5 cm hold the slab; the 7th (80 %) is first reached by particle j = 12.
        CHECK(bins[0].time == Approx(0.112));
        CHECK(bins[0].startDepthFraction == Approx(0.0).margin(1e-6));
        CHECK(bins[0].startTime == Approx(0.1)); // particle j = 0, the bottom row

        SlabFractureTracker tracker;
        const CrackTracker crack = runningCrack();
        tracker.update(samples, kDx, 2, 0.2, crack);
        REQUIRE(tracker.fractures().size() == 1);
        const SlabFracture& f = tracker.fractures()[0];
        CHECK(f.x == Approx(1.025));
        CHECK(f.y == Approx(0.1125));
        CHECK(f.time == Approx(0.112));
        CHECK(f.startDepthFraction == Approx(0.0).margin(1e-6));
        // tip at 0.112 s: 1.5 + 10 m/s * 0.112 s = 2.62 m, ahead of the fracture
        CHECK(f.distanceBehindCrackTip == Approx(2.62 - 1.025));
        // where it began, at 0.1 s: the tip at 1.5 + 10 m/s * 0.1 s = 2.5 m
        CHECK(f.startTime == Approx(0.1));
        CHECK(f.distanceBehindCrackTipAtStart == Approx(2.5 - 1.025));
        CHECK(tracker.fracturedMassFraction() == Approx(32.0 / (80 * 16)));
    }
    SECTION("from the top (as in the PST)") {
        const auto samples = flatSlab(
            2.0, [](int i, int j) { return i == 40 || i == 41 ? 0.1 + 0.001 * (15 - j) : -1.0; });
        const auto bins = findThroughBins(samples, kDx, 2);
        REQUIRE(bins.size() == 1);
        CHECK(bins[0].startDepthFraction == Approx(1.0));
        CHECK(bins[0].startTime == Approx(0.1)); // particle j = 15, the top row
        CHECK(bins[0].time == Approx(0.112));
        SlabFractureTracker tracker;
        tracker.update(samples, kDx, 2, 0.2, CrackTracker{});
        REQUIRE(tracker.fractures().size() == 1);
        CHECK(std::isnan(tracker.fractures()[0].distanceBehindCrackTip)); // no weak layer crack
        CHECK(std::isnan(tracker.fractures()[0].distanceBehindCrackTipAtStart));
    }
}

TEST_CASE("a crack part way through the slab is no slab fracture", "[slab_fracture]") {
    // The lower 12 of 16 particle rows: 6 of the 8 cell rows, 75 % < 80 %.
    const auto samples =
        flatSlab(2.0, [](int i, int j) { return (i == 40 || i == 41) && j < 12 ? 0.1 : -1.0; });
    CHECK(findThroughBins(samples, kDx, 2).empty());
    SlabFractureTracker tracker;
    tracker.update(samples, kDx, 2, 0.2, runningCrack());
    CHECK(tracker.fractures().empty());
    CHECK(tracker.blocks().count == 1); // the slab still holds together above the crack
}

TEST_CASE("a fracture is recorded once, and a new one apart from it is recorded too",
          "[slab_fracture]") {
    // Bins 20 and 21 go through at 0.11 and 0.12 s: one fracture at bin 20. Later bin 22 joins
    // it, and bin 30 fractures on its own.
    const auto early = [](int i, int) {
        return i >= 40 && i < 42 ? 0.11 : i >= 42 && i < 44 ? 0.12 : -1.0;
    };
    const auto later = [&](int i, int j) {
        if (i >= 44 && i < 46) return 0.25;
        if (i >= 60 && i < 62) return 0.3;
        return early(i, j);
    };
    SlabFractureTracker tracker;
    const CrackTracker crack = runningCrack();
    tracker.update(flatSlab(2.0, early), kDx, 2, 0.2, crack);
    REQUIRE(tracker.fractures().size() == 1);
    CHECK(tracker.fractures()[0].x == Approx(1.025));
    CHECK(tracker.fractures()[0].time == Approx(0.11));
    tracker.update(flatSlab(2.0, early), kDx, 2, 0.25, crack); // nothing new
    CHECK(tracker.fractures().size() == 1);
    tracker.update(flatSlab(2.0, later), kDx, 2, 0.4, crack);
    REQUIRE(tracker.fractures().size() == 2);
    CHECK(tracker.fractures()[1].x == Approx(1.525));
    CHECK(tracker.fractures()[1].time == Approx(0.3));
    // after the tracker's last frame its tip stays at 3.5 m
    CHECK(tracker.fractures()[1].distanceBehindCrackTip == Approx(3.5 - 1.525));
}

TEST_CASE("a fracture up-slope of the trigger lies behind the up-slope tip, while the "
          "down-slope end leads",
          "[slab_fracture]") {
    // The crack starts at [1.5, 1.6] m and runs both ways: by 0.04 s up to 1.0 m (12.5 m/s) and
    // down to 2.5 m (22.5 m/s, the leading end). The slab breaks at x 1.225 m (bin 24) at 0.04 s,
    // up-slope of the start: 0.225 m behind the up-slope tip that passed it, not 1.275 m behind
    // the leading one on the other side.
    CrackTracker crack;
    FrameDiagnostics d;
    d.hasWeakLayer = true;
    d.intactMinX = 0.0, d.intactMaxX = 4.0; // the layer beyond both ends
    d.crackMinX = 1.5, d.crackMaxX = 1.6;
    crack.update(d, 0.0);
    d.crackMinX = 1.0, d.crackMaxX = 2.5;
    crack.update(d, 0.04);
    REQUIRE(crack.direction() == 1);
    SlabFractureTracker tracker;
    tracker.update(flatSlab(2.0, [](int i, int) { return i == 48 || i == 49 ? 0.04 : -1.0; }), kDx,
                   2, 0.05, crack);
    REQUIRE(tracker.fractures().size() == 1);
    CHECK(tracker.fractures()[0].x == Approx(1.225));
    CHECK(tracker.fractures()[0].distanceBehindCrackTip == Approx(1.225 - 1.0));
    // Down-slope of the start it is the leading end's: 2.5 - 1.725 m.
    CHECK(crack.distanceBehind(1.725, 0.04) == Approx(2.5 - 1.725));
    // An end that has not propagated (creep below kMinCrackSpeed) is no tip: the leading one is.
    CrackTracker oneWay;
    d.crackMinX = 1.5, d.crackMaxX = 1.6;
    oneWay.update(d, 0.0);
    d.crackMinX = 1.45, d.crackMaxX = 2.5;
    oneWay.update(d, 0.04);
    CHECK(oneWay.distanceBehind(1.225, 0.04) == Approx(2.5 - 1.225));
}

TEST_CASE("a slab cut through by a fracture is two blocks", "[slab_fracture]") {
    // Bin 20 (x in [1.0, 1.05)) fully fractured: bins 0-19 on the left, 21-39 on the right.
    const auto samples = flatSlab(2.0, [](int i, int) { return i == 40 || i == 41 ? 0.1 : -1.0; });
    const SlabBlocks blocks = findSlabBlocks(samples, kDx, 2);
    CHECK(blocks.count == 2);
    CHECK(blocks.largestMass == Approx(20 * 32));
    CHECK(blocks.medianMass == Approx(0.5 * (20 * 32 + 19 * 32)));
    const SlabBlocks whole = findSlabBlocks(flatSlab(2.0, [](int, int) { return -1.0; }), kDx, 2);
    CHECK(whole.count == 1);
    CHECK(whole.largestMass == Approx(80 * 16));
    CHECK(findSlabBlocks({}, kDx, 2).count == 0);
}

TEST_CASE("in 3D a fracture across the slope is one fracture and cuts the slab in two",
          "[slab_fracture]") {
    // 1 m along x, 0.5 m across z; x in [0.5, 0.55) fractures from the bottom, the same
    // moment all across.
    const auto samples = flatSlab(
        1.0, [](int i, int j) { return i == 20 || i == 21 ? 0.1 + 0.001 * j : -1.0; }, 20);
    const auto bins = findThroughBins(samples, kDx, 3);
    CHECK(bins.size() == 10); // the 10 bins across z
    SlabFractureTracker tracker;
    tracker.update(samples, kDx, 3, 0.2, runningCrack());
    REQUIRE(tracker.fractures().size() == 1);
    CHECK(tracker.fractures()[0].x == Approx(0.525));
    CHECK(tracker.fractures()[0].z == Approx(0.025)); // ties go to the lowest z
    CHECK(tracker.fractures()[0].startDepthFraction == Approx(0.0).margin(1e-6));
    CHECK(tracker.blocks().count == 2);
}

TEST_CASE("slab fracture results do not depend on the particle order", "[slab_fracture]") {
    const auto samples = flatSlab(2.0, [](int i, int j) {
        if (i == 40 || i == 41) return 0.1 + 0.001 * j;
        if (i >= 60 && i < 63 && j > 3) return 0.05 + 0.0001 * i; // partial, not through
        return -1.0;
    });
    auto shuffled = samples;
    std::shuffle(shuffled.begin(), shuffled.end(), std::mt19937(7));
    const auto a = findThroughBins(samples, kDx, 2), b = findThroughBins(shuffled, kDx, 2);
    REQUIRE(a.size() == b.size());
    for (std::size_t k = 0; k < a.size(); ++k) {
        CHECK(a[k].ix == b[k].ix);
        CHECK(a[k].time == b[k].time);
        CHECK(a[k].startDepthFraction == b[k].startDepthFraction);
    }
    const SlabBlocks ba = findSlabBlocks(samples, kDx, 2), bb = findSlabBlocks(shuffled, kDx, 2);
    CHECK(ba.count == bb.count);
    CHECK(ba.largestMass == bb.largestMass);
    CHECK(ba.medianMass == bb.medianMass);
}

TEST_CASE("slab samples measure height and foot point along the bed's normal", "[slab_fracture]") {
    const std::string text =
        "[simulation]\nname = \"bed\"\ndimension = 2\nend_time = 0.1\n"
        "[grid]\ndx = 0.05\nparticles_per_cell = 4\n"
        "[[material]]\nname = \"slab\"\nmodel = \"snow\"\n"
        "[[material]]\nname = \"weak\"\nmodel = \"weak_layer\"\n"
        "[[terrain]]\nshape = \"plane\"\npoint = [0.0, 0.0]\nnormal = [0.5, 0.8660254]\n"
        "[[body]]\nname = \"weak\"\nmaterial = \"weak\"\nshape = \"layer\"\nthickness = 0.1\n"
        "x_range = [0.0, 2.0]\n"
        "[[body]]\nmaterial = \"slab\"\nshape = \"layer\"\non_top_of = \"weak\"\n"
        "thickness = 0.3\nx_range = [0.0, 2.0]\n";
    const auto world = buildWorld(test::sceneFromText(text), BuildStage::Seeded);
    const auto samples = slabSamples(*world);
    REQUIRE(samples.size() == world->particlesPerBody[1]); // the weak layer is no slab
    const Vec3f normal(0.5f, 0.8660254f, 0.f);
    for (const SlabSample& s : samples) {
        CHECK(s.height >= 0.1f - 1e-4f);
        CHECK(s.height <= 0.4f + 1e-4f);
        CHECK(s.height == Approx(normal.dot(s.position)).margin(1e-5));
        const Vec3f foot(s.bedX, 0.f, 0.f);
        CHECK((s.position - s.height * normal)[0] == Approx(foot[0]).margin(1e-5));
    }
}

namespace {

/// A 2 m snow slab on a 30 degree slip slope, its up-slope half moving up-slope and its
/// down-slope half down-slope at 1 m/s: the tension at x = 1 m is some 30 times the slab's
/// tensile strength beta p0 = 600 Pa, so the slab must break there, in tension, through its
/// whole thickness.
std::string pulledSlabScene() {
    return "[simulation]\nname = \"pulled-slab\"\ndimension = 2\nend_time = 0.06\n"
           "frame_rate = 200\ngravity = [0.0, 0.0]\n"
           "[grid]\ndx = 0.05\nparticles_per_cell = 4\n"
           "[[material]]\nname = \"slab\"\nmodel = \"snow\"\ndensity = 250.0\n"
           "youngs_modulus = 1.0e6\npoisson_ratio = 0.3\ninitial_p0 = 2000.0\n"
           "[[terrain]]\nshape = \"plane\"\npoint = [0.0, 0.0]\nnormal = [0.5, 0.8660254]\n"
           "boundary = \"slip\"\n"
           "[[body]]\nmaterial = \"slab\"\nshape = \"layer\"\nthickness = 0.3\n"
           "x_range = [0.0, 1.0]\nvelocity = [-0.8660254, 0.5]\n"
           "[[body]]\nmaterial = \"slab\"\nshape = \"layer\"\nthickness = 0.3\n"
           "x_range = [1.0, 2.0]\nvelocity = [0.8660254, -0.5]\n";
}

std::string slurp(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

} // namespace

TEST_CASE("a slab pulled apart fractures in tension where it is pulled", "[slab_fracture]") {
    const SceneDesc scene = test::sceneFromText(pulledSlabScene(), "pulled-slab");
    const auto fracturesWith = [&](int threads) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        auto world = buildWorld(scene);
        SlabFractureTracker tracker;
        const CrackTracker noCrack;
        tracker.update(slabSamples(*world), world->dx, 2, world->time, noCrack);
        REQUIRE(tracker.fractures().empty()); // intact at t = 0
        REQUIRE(tracker.blocks().count == 1);
        for (int k = 1; k <= 12; ++k) {
            test::advanceTo(*world, k * 0.005);
            tracker.update(slabSamples(*world), world->dx, 2, world->time, noCrack);
        }
        return tracker;
    };
    const SlabFractureTracker tracker = fracturesWith(2);
    REQUIRE(tracker.fractures().size() >= 1);
    const SlabFracture& first = tracker.fractures().front();
    INFO("first fracture at x = " << first.x << " m, t = " << first.time << " s");
    CHECK(std::abs(first.x - 1.0) < 0.15);
    CHECK(first.time < 0.02);
    CHECK(first.startTime <= first.time);
    CHECK(std::isnan(first.distanceBehindCrackTip));
    CHECK(tracker.blocks().count >= 2);
    CHECK(tracker.fracturedMassFraction() < 0.5); // the halves themselves stay whole

    const SlabFractureTracker serial = fracturesWith(1);
    REQUIRE(serial.fractures().size() == tracker.fractures().size());
    for (std::size_t k = 0; k < serial.fractures().size(); ++k) {
        CHECK(serial.fractures()[k].x == tracker.fractures()[k].x);
        CHECK(serial.fractures()[k].time == tracker.fractures()[k].time);
        CHECK(serial.fractures()[k].startDepthFraction ==
              tracker.fractures()[k].startDepthFraction);
        CHECK(serial.fractures()[k].startTime == tracker.fractures()[k].startTime);
    }
    CHECK(serial.blocks().count == tracker.blocks().count);

    SECTION("firn run writes the fractures to metrics.csv and summary.json") {
        test::TempDir dir("firn-slab-fracture");
        RunOptions options;
        options.outDir = dir.path();
        options.quiet = true;
        REQUIRE(runScene(scene, options).status == "ok");
        const std::string summary = slurp(dir.path() + "/summary.json");
        const std::string count = std::to_string(tracker.fractures().size());
        CHECK(summary.find("\"slab_fracture_count\": " + count + ",") != std::string::npos);
        CHECK(summary.find("\"first_slab_fracture_time\": ") != std::string::npos);
        CHECK(summary.find("\"start_depth_fraction\": ") != std::string::npos);
        CHECK(summary.find("\"distance_behind_crack_tip\": null") != std::string::npos);
        CHECK(summary.find("\"start_time\": ") != std::string::npos);
        CHECK(summary.find("\"distance_behind_crack_tip_at_start\": null") != std::string::npos);
        CHECK(summary.find("\"final_slab_blocks\": ") != std::string::npos);
        const std::string metrics = slurp(dir.path() + "/metrics.csv");
        const std::string header = metrics.substr(0, metrics.find('\n'));
        for (const char* column : {"slab_fractures", "slab_fractured_fraction", "slab_blocks",
                                   "largest_block_mass", "median_block_mass"})
            CHECK(header.find(column) != std::string::npos);
    }
}
