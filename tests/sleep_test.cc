// Sleeping: resting snow stops costing G2P and plasticity, stays where it is, and wakes when
// something hits it.
#include <firn/solver.h>

#include "test_util.h"

#include <catch2/catch.hpp>
#include <tbb/global_control.h>

using namespace firn;

namespace {

// A 2 m x 0.4 m elastic block on the ground; a ball 4 m above its left end falls on it after
// ~0.95 s. Leaves are 0.8 m (8 x dx 0.1), so the ball is more than a leaf away from the block
// until it lands: the block can sleep before the impact.
std::unique_ptr<World> blockAndBall(bool sleep) {
    const std::string text = std::string(R"([simulation]
name = "sleep"
dimension = 2
gravity = [0.0, -9.81]
gravity_ramp = 0.1
[grid]
dx = 0.1
particles_per_cell = 4
max_dt = 2e-3
sleep = )") + (sleep ? "true" : "false") +
                             R"(
sleep_steps = 50
[[material]]
name = "snow"
model = "elastic"
density = 300.0
youngs_modulus = 2e5
poisson_ratio = 0.3
[[terrain]]
shape = "plane"
point = [0.0, 0.0]
normal = [0.0, 1.0]
boundary = "sticky"
[[body]]
material = "snow"
shape = "box"
min = [0.0, 0.0]
max = [2.0, 0.4]
[[body]]
material = "snow"
shape = "sphere"
center = [0.5, 4.5]
radius = 0.25
)";
    return buildWorld(test::sceneFromText(text, "sleep"));
}

} // namespace

TEST_CASE("A resting block falls asleep, stays put, and a falling ball wakes it", "[sleep]") {
    auto world = blockAndBall(true);
    const std::size_t block = world->particlesPerBody[0];
    // Before the impact: the block asleep, the ball awake.
    test::advanceTo(*world, 0.6);
    CHECK(asleepCount(*world) >= block * 9 / 10);
    CHECK(asleepCount(*world) <= block);
    // Asleep particles do not move at all.
    const std::vector<Vec3f> before = world->particles.x;
    std::vector<bool> wasAsleep(before.size());
    for (std::size_t i = 0; i < before.size(); ++i) wasAsleep[i] = world->particles.asleep(i);
    step(*world, stableTimeStep(*world));
    for (std::size_t i = 0; i < before.size(); ++i) {
        if (wasAsleep[i] && world->particles.asleep(i)) REQUIRE(world->particles.x[i] == before[i]);
    }
    // After the impact the block near the ball has woken.
    test::advanceTo(*world, 1.2);
    CHECK(asleepCount(*world) < block / 2);
}

TEST_CASE("Sleeping changes a settled block by less than a hundredth of a cell", "[sleep]") {
    // Without the ball: the block settles under gravity with sleeping on and off.
    auto on = blockAndBall(true);
    auto off = blockAndBall(false);
    test::advanceTo(*on, 0.7);
    test::advanceTo(*off, 0.7);
    const std::size_t block = on->particlesPerBody[0];
    double sumOn = 0, sumOff = 0;
    for (std::size_t i = 0; i < on->particles.size(); ++i) {
        if (on->particles.x[i][1] < 1.0) sumOn += on->particles.x[i][1];
        if (off->particles.x[i][1] < 1.0) sumOff += off->particles.x[i][1];
    }
    // Mean height of the block: the same within 1e-3 m (dx / 100). Sleeping freezes particles
    // slower than 2 cm/s; the elastic settling left at 0.7 s is far below that.
    CHECK(std::abs(sumOn - sumOff) / block < 1e-3);
}

TEST_CASE("Sleeping and waking give the same state for 1 and 2 threads", "[sleep][determinism]") {
    auto runWith = [](int threads) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        auto world = blockAndBall(true);
        test::advanceTo(*world, 1.2); // through sleep (~0.2 s), the impact and the waking
        return world;
    };
    const auto one = runWith(1);
    const auto two = runWith(2);
    REQUIRE(one->particles.size() == two->particles.size());
    CHECK(asleepCount(*one) == asleepCount(*two));
    for (std::size_t i = 0; i < one->particles.size(); ++i) {
        REQUIRE(one->particles.x[i] == two->particles.x[i]);
        REQUIRE(one->particles.v[i] == two->particles.v[i]);
    }
}

TEST_CASE("A column beyond its strength collapses with sleeping on as with it off", "[sleep]") {
    // A cohesionless sand column, 0.1 m square on a sticky floor (V7's column at a = 1, dx 0.005,
    // stiff: E 10 MPa). It starts from rest and accelerates slowly at first: slower than the
    // 2 cm/s sleep speed for its first 100 steps, so a sleep test on speed alone froze the whole
    // column standing (max_speed 0 over 0.6 s). At rest must also mean not accelerating.
    auto column = [](bool sleep) {
        const std::string text = std::string(R"([simulation]
name = "column"
dimension = 2
gravity = [0.0, -9.81]
[grid]
dx = 0.005
particles_per_cell = 4
sleep = )") + (sleep ? "true" : "false") +
                                 R"(
[[material]]
name = "sand"
model = "granular"
density = 1500.0
youngs_modulus = 1.0e7
poisson_ratio = 0.3
friction_angle = 30.0
[[terrain]]
shape = "plane"
point = [0.0, 0.0]
normal = [0.0, 1.0]
boundary = "sticky"
[[terrain]]
shape = "plane"
point = [0.0, 0.0]
normal = [1.0, 0.0]
boundary = "slip"
[[body]]
material = "sand"
shape = "box"
min = [0.0, 0.0]
max = [0.1, 0.1]
)";
        auto world = buildWorld(test::sceneFromText(text, "column"));
        test::advanceTo(*world, 0.4);
        float front = 0.f;
        for (const Vec3f& x : world->particles.x) front = std::max(front, x[0]);
        return front;
    };
    const float on = column(true), off = column(false);
    // The column spreads to about twice its width (Lube's law: runout L0 (1 + 1.2 a)); the front
    // with sleeping on lies within a cell of the front without.
    CHECK(off > 0.17f);
    CHECK(std::abs(on - off) < 0.005f);
}
