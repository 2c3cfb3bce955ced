// Frame diagnostics: crack tracking and the stability watch, on synthetic frames.
#include "test_util.h"

#include <firn/diagnostics.h>

#include <catch2/catch.hpp>

using namespace firn;

namespace {

FrameDiagnostics crackFrame(double minX, double maxX) {
    FrameDiagnostics d;
    d.hasWeakLayer = true;
    d.crackMinX = minX;
    d.crackMaxX = maxX;
    return d;
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
