// Hazard runs: the stop criterion (RestDetector, firn/hazard.h) frame by frame.
#include <firn/hazard.h>

#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <vector>

using namespace firn;

namespace {

struct Frame {
    double kineticEnergy;
    double comPathLength;
};

/// The index of the first frame the detector calls at rest, or -1.
int firstAtRest(RestDetector& rest, const std::vector<Frame>& frames) {
    for (std::size_t k = 0; k < frames.size(); ++k)
        if (rest.atRest(frames[k].kineticEnergy, frames[k].comPathLength)) return int(k);
    return -1;
}

} // namespace

TEST_CASE("A flow that rises and decays is at rest at the first frame below 1 % of its peak",
          "[hazard]") {
    RestDetector rest(0.01, 2.0);
    const std::vector<Frame> frames = {{0.0, 0.0},   {10.0, 0.5},   {50.0, 3.0},
                                       {100.0, 9.0}, {40.0, 20.0},  {5.0, 26.0},
                                       {1.0, 27.0},  {0.999, 27.1}, {0.001, 27.1}};
    CHECK(firstAtRest(rest, frames) == 7); // 1.0 is not below 1 % of 100; 0.999 is
    CHECK(rest.peakKineticEnergy() == 100.0);
    CHECK(rest.ratio() == Approx(0.00999));
    CHECK(rest.released());
}

TEST_CASE("A scene that never moves one cell is never at rest, however small its energy",
          "[hazard]") {
    // A settled slope: kinetic energy at round-off level that falls by orders of magnitude,
    // the centre of mass creeping 1.9 cm in all.
    RestDetector rest(0.01, 0.02);
    std::vector<Frame> frames;
    for (int k = 0; k < 100; ++k) frames.push_back({1e-9 * std::pow(0.5, k), 0.019 * k / 99.0});
    CHECK(firstAtRest(rest, frames) == -1);
    CHECK_FALSE(rest.released());
    CHECK(rest.ratio() < 0.01); // it would have stopped had it moved
}

TEST_CASE("The release must have moved before the criterion applies", "[hazard]") {
    // The energy peaks while the centre of mass is still within a cell (a slab's elastic
    // rebound), then the slab slides off: the stop waits for the slide's own decay.
    RestDetector rest(0.01, 1.0);
    const std::vector<Frame> frames = {{5.0, 0.0},  {0.01, 0.1}, {20.0, 0.5},
                                       {80.0, 2.0}, {0.5, 4.0},  {0.1, 4.1}};
    // Frame 1 is below 1 % of 5 but nothing has moved a cell; frame 4 is 0.6 % of 80.
    CHECK(firstAtRest(rest, frames) == 4);
}

TEST_CASE("A non-finite energy is left to the stability watch", "[hazard]") {
    RestDetector rest(0.01, 0.0);
    CHECK_FALSE(rest.atRest(std::nan(""), 1.0));
    CHECK_FALSE(rest.atRest(std::numeric_limits<double>::infinity(), 1.0));
    CHECK(rest.peakKineticEnergy() == 0.0);
    CHECK_FALSE(rest.atRest(0.0, 1.0)); // a peak of 0 stops nothing
}

TEST_CASE("The detector resumes from a checkpoint where it was", "[hazard][checkpoint]") {
    RestDetector rest(0.05, 1.0);
    CHECK_FALSE(rest.atRest(10.0, 0.5));
    CHECK_FALSE(rest.atRest(30.0, 1.5));
    ByteWriter out;
    rest.save(out);
    const std::string bytes = out.bytes();
    RestDetector resumed(0.05, 1.0);
    ByteReader in(bytes.data(), bytes.size());
    resumed.load(in);
    CHECK(resumed.peakKineticEnergy() == 30.0);
    CHECK(resumed.released());
    CHECK_FALSE(resumed.atRest(1.6, 2.0)); // 5.3 % of 30
    CHECK(resumed.atRest(1.4, 2.0));       // 4.7 %
}

TEST_CASE("Distance along a path: the foot point's arc length, the ends extended",
          "[hazard][path]") {
    const PathLine straight = {{0.0, 0.0}, {100.0, 0.0}};
    CHECK(distanceAlongPath(straight, 40.0, 7.0) == Approx(40.0));    // lateral offset ignored
    CHECK(distanceAlongPath(straight, -5.0, 1.0) == Approx(-5.0));    // a crown above the start
    CHECK(distanceAlongPath(straight, 130.0, -2.0) == Approx(130.0)); // past the end
    // An L: 10 m east, then 10 m north. A point beside the second leg measures along the first
    // leg and then up the second; one beyond the end continues along the last leg.
    const PathLine bend = {{0.0, 0.0}, {10.0, 0.0}, {10.0, 0.0}, {10.0, 10.0}};
    CHECK(distanceAlongPath(bend, 10.5, 5.0) == Approx(15.0));
    CHECK(distanceAlongPath(bend, 9.0, 16.0) == Approx(26.0));
    CHECK(distanceAlongPath(bend, 4.0, -1.0) == Approx(4.0));
    CHECK(distanceAlongPath({{3.0, 4.0}}, 0.0, 0.0) == Approx(5.0));
}

TEST_CASE("Alpha along a straight path is alpha along x, and on a bend it follows the path",
          "[hazard][path]") {
    // A straight path along x: the angle of the line from the top to the farthest cell.
    const std::array<double, 3> top = {0.0, 300.0, 0.0};
    std::vector<std::array<double, 3>> footprint;
    for (int k = 1; k <= 20; ++k) footprint.push_back({25.0 * k, 300.0 - 10.0 * k, 3.0});
    const RunoutAlongPath straight = runoutAlongPath({{0.0, 0.0}, {1.0, 0.0}}, top, footprint);
    REQUIRE(straight.found);
    CHECK(straight.length == Approx(500.0));
    CHECK(straight.point[0] == 500.0);
    CHECK(straight.alphaDeg == Approx(std::atan2(200.0, 500.0) * 180.0 / M_PI));
    // A path that turns 90 degrees after 300 m: the deposit lies north of the bend, 200 m up
    // the second leg. Along x the run would be 300 m long; along the path it is 500 m.
    const PathLine bend = {{0.0, 0.0}, {300.0, 0.0}, {300.0, 400.0}};
    std::vector<std::array<double, 3>> turned = {
        {150.0, 250.0, 0.0}, {300.0, 150.0, 100.0}, {302.0, 100.0, 200.0}, {299.0, 120.0, 190.0}};
    const RunoutAlongPath along = runoutAlongPath(bend, top, turned);
    CHECK(along.length == Approx(500.0));
    CHECK(along.point[2] == 200.0);
    CHECK(along.alphaDeg == Approx(std::atan2(200.0, 500.0) * 180.0 / M_PI));
    CHECK_FALSE(runoutAlongPath(bend, top, {}).found);
}

TEST_CASE("A centre of mass's track becomes a path without its resting jitter", "[hazard][path]") {
    const PathLine track = {{0.0, 0.0}, {0.01, 0.0}, {5.0, 0.0}, {10.0, 1.0}, {10.02, 1.01}};
    const PathLine path = pathFromTrack(track, 0.5);
    REQUIRE(path.size() == 3);
    CHECK(path[2][0] == 10.0);
}
