// Snowpacks that start at rest (src/settle): a scene settles under gravity before t = 0, so a
// block at a stick angle does not creep and a weak layer loaded below its strength does not
// fail from the dynamic overshoot of a stress-free start (twice the static load).
#include "test_util.h"

#include <firn/diagnostics.h>

#include <catch2/catch.hpp>

#include <cmath>
#include <string>

using namespace firn;

namespace {

/// An elastic block 1 m x 0.5 m on a floor with gravity tilted to 25 degrees (x down-slope),
/// Coulomb friction 0.5 (tan 25 = 0.466: it sticks), no gravity ramp: the default start.
std::string tiltedBlock(double youngsModulus) {
    return R"([simulation]
name = "block"
dimension = 2
end_time = 1.0
gravity = [4.14584, -8.89084]
[grid]
dx = 0.05
particles_per_cell = 4
sleep = false
[[material]]
name = "block"
model = "elastic"
density = 250.0
poisson_ratio = 0.3
youngs_modulus = )" +
           std::to_string(youngsModulus) +
           R"(
[[terrain]]
shape = "plane"
point = [0.0, 0.0]
normal = [0.0, 1.0]
boundary = "friction"
friction = 0.5
[[body]]
material = "block"
shape = "box"
min = [1.0, 0.0]
max = [2.0, 0.5]
)";
}

Vec3f centreOfMass(const World& w) {
    return computeDiagnostics(w).centreOfMass.cast<float>();
}

/// A 0.4 m snow slab on a 6 cm weak layer on a 35 degree slope (tilted gravity), 4 m long. The
/// weak layer's strength (initial_p0) is set so that its static shear after settling is about
/// 80 % of what it can carry at its confinement (checked by the test). The cut, when given, is
/// at the down-slope end. The collapsed layer's slope M_d = 0.5 (crack-face friction ~16 deg in
/// plane strain) lets the slab slide on 35 degrees once the layer has collapsed (Gaume et al.
/// 2019: the slab releases where the slope exceeds the weak layer's friction angle). The bed is
/// Coulomb with mu 1.0 > tan 35: it holds the column, and the slab where it lands in the cut
/// slides on instead of sticking.
std::string slabOnSlope(double cutLength, bool settle) {
    std::string text = R"([simulation]
name = "slope"
dimension = 2
end_time = 1.0
gravity = [5.62680, -8.03590]
)" + std::string(settle ? "" : "settle = false\n") +
                       R"([grid]
dx = 0.03
particles_per_cell = 4
jitter = 0.0
[[material]]
name = "slab"
model = "snow"
density = 250.0
youngs_modulus = 5.0e6
poisson_ratio = 0.2
critical_state_slope = 1.0
cohesion_ratio = 0.5
initial_p0 = 6.0e4
hardening = 0.5
[[material]]
name = "weak"
model = "weak_layer"
density = 100.0
youngs_modulus = 4.8e5
poisson_ratio = 0.2
critical_state_slope = 1.0
cohesion_ratio = 0.1
initial_p0 = 3350.0
hardening = 0.015
softening = 100.0
dynamic_critical_state_slope = 0.5
[[terrain]]
shape = "plane"
point = [0.0, 0.0]
normal = [0.0, 1.0]
boundary = "friction"
friction = 1.0
[[body]]
name = "weak"
material = "weak"
shape = "layer"
thickness = 0.06
x_range = [0.0, 4.0]
[[body]]
name = "slab"
material = "slab"
shape = "layer"
on_top_of = "weak"
thickness = 0.4
x_range = [0.0, 4.0]
)";
    if (cutLength > 0)
        text += "[[cut]]\nlayer = \"weak\"\nfrom_x = " + std::to_string(4.0 - cutLength) +
                "\nlength = " + std::to_string(cutLength) + "\n";
    return text;
}

/// Mean q / q_y(p) over the weak layer's particles away from the column ends: how much of its
/// strength the static load uses (eq. 1 at the particle's p, with its current p0).
double weakLayerLoadRatio(const World& w) {
    const ParticleSet& ps = w.particles;
    double ratio = 0.0;
    std::size_t count = 0;
    for (std::size_t i = 0; i < ps.size(); ++i) {
        const Material& m = w.materials[ps.material[i]];
        if (m.model != MaterialModel::WeakLayer || ps.x[i][0] < 0.5f || ps.x[i][0] > 3.5f) continue;
        const Sym3f& t = ps.tau[i];
        const Vec3f tauPrincipal =
            Vec3f(0.5f * (t.xx + t.yy) + std::hypot(0.5f * (t.xx - t.yy), t.xy),
                  0.5f * (t.xx + t.yy) - std::hypot(0.5f * (t.xx - t.yy), t.xy), 0.f);
        const StressInvariants inv = stressInvariants(tauPrincipal, 2);
        const float K = m.lame.bulkModulus(2);
        const float p0 = camClayP0(K, m.camClay.xi, ps.plastic[i].hardening);
        const float beta = m.camClay.beta;
        const float qy = m.camClay.M * std::sqrt(std::max(0.f, (inv.p + beta * p0) * (p0 - inv.p)) /
                                                 (1.f + 2.f * beta));
        ratio += double(inv.q / qy);
        ++count;
    }
    return count ? ratio / double(count) : 0.0;
}

/// Weak-layer particles that have yielded, at least `margin` from the ends of the 4 m column
/// (the free ends of a finite layer concentrate stress: an infinite slope has none).
std::size_t failedWeakLayer(const World& w, float margin = 0.f) {
    std::size_t n = 0;
    for (std::size_t i = 0; i < w.particles.size(); ++i)
        if (w.materials[w.particles.material[i]].model == MaterialModel::WeakLayer &&
            (w.particles.plastic[i].flags & kFlagFailed) && w.particles.x[i][0] >= margin &&
            w.particles.x[i][0] <= 4.f - margin)
            ++n;
    return n;
}

} // namespace

TEST_CASE("Settling: a block at a stick angle starts at rest and stays there, E 0.5-10 MPa",
          "[validation][settle]") {
    // validation.md V1 (stick): displacement after 1 s below 1e-3 dx = 5e-5 m, with no gravity
    // ramp in the scene. Without settling the stress-free block bounces on its elastic base and
    // the contact force (so the friction) oscillates: it creeps (README, Validation).
    for (const double E : {0.5e6, 1e6, 10e6}) {
        INFO("E = " << E);
        auto w = buildWorld(test::sceneFromText(tiltedBlock(E)));
        CHECK(w->settle.ran);
        CHECK(w->settle.converged);
        CHECK(w->settle.overloaded == 0);
        CHECK(w->time == 0.0);
        const Vec3f start = centreOfMass(*w);
        test::advanceTo(*w, 1.0);
        const float moved = (centreOfMass(*w) - start).norm();
        INFO("settled in " << w->settle.time << " s (" << w->settle.steps << " steps); moved "
                           << moved << " m in 1 s");
        CHECK(moved < 5e-5f);
    }
    // The test can fail: the same block started stress-free under full gravity creeps.
    SceneDesc scene = test::sceneFromText(tiltedBlock(1e6));
    scene.simulation.settle = false;
    auto w = buildWorld(scene);
    const Vec3f start = centreOfMass(*w);
    test::advanceTo(*w, 1.0);
    CHECK((centreOfMass(*w) - start).norm() > 5e-5f);
}

TEST_CASE("Settling: a weak layer at 80 % of its strength holds, and a long cut releases the slab",
          "[validation][settle][pst]") {
    auto w = buildWorld(test::sceneFromText(slabOnSlope(0.0, true)));
    const double ratio = weakLayerLoadRatio(*w);
    INFO("static q / q_y in the weak layer: " << ratio << "; settled in " << w->settle.time
                                              << " s");
    REQUIRE(w->settle.converged);
    // The scene is what the issue asks for: the static shear uses ~80 % of the strength.
    REQUIRE(ratio > 0.75);
    REQUIRE(ratio < 0.85);
    INFO("yielded at the ends at t = 0: " << failedWeakLayer(*w));
    CHECK(failedWeakLayer(*w, 0.1f) == 0);
    test::advanceTo(*w, 1.0);
    CHECK(failedWeakLayer(*w, 0.1f) == 0); // nothing fails without a trigger

    // Without settling the overshoot of a stress-free start (about twice the static load)
    // fails the same layer: what settling prevents.
    auto bounced = buildWorld(test::sceneFromText(slabOnSlope(0.0, false)));
    test::advanceTo(*bounced, 0.2);
    CHECK(failedWeakLayer(*bounced) > 100);

    // A long cut at the down-slope end: the crack runs up the slope and the slab slides.
    auto cut = buildWorld(test::sceneFromText(slabOnSlope(1.5, true)));
    const Vec3f start = centreOfMass(*cut);
    test::advanceTo(*cut, 0.6);
    const FrameDiagnostics d = computeDiagnostics(*cut);
    const float slid = centreOfMass(*cut)[0] - start[0];
    INFO("crack from " << d.crackMinX << " to " << d.crackMaxX << " m, max speed " << d.maxSpeed
                       << " m/s, centre of mass " << slid << " m down-slope");
    CHECK(d.crackMinX < 0.5); // to the up-slope end of the 4 m column
    CHECK(d.maxSpeed > 0.3);  // the slab has released and slides
    CHECK(slid > 0.05f);
}

TEST_CASE("Settling: bodies in the air or moving wait outside and join at t = 0 as seeded",
          "[settle]") {
    const std::string text = R"([simulation]
name = "air"
dimension = 2
[grid]
dx = 0.05
particles_per_cell = 4
[[material]]
name = "m"
model = "elastic"
youngs_modulus = 1e6
[[terrain]]
shape = "plane"
point = [0.0, 0.0]
normal = [0.0, 1.0]
[[body]]
material = "m"
shape = "box"
min = [0.0, 0.0]
max = [1.0, 0.5]
[[body]]
material = "m"
shape = "box"
min = [0.0, 0.5]
max = [1.0, 0.7]
[[body]]
material = "m"
shape = "sphere"
center = [0.5, 2.0]
radius = 0.2
[[body]]
material = "m"
shape = "box"
min = [2.0, 0.0]
max = [2.5, 0.5]
velocity = [1.0, 0.0]
)";
    auto seeded = buildWorld(test::sceneFromText(text), BuildStage::Seeded);
    auto settled = buildWorld(test::sceneFromText(text));
    REQUIRE(settled->settle.converged);
    REQUIRE(seeded->particles.size() == settled->particles.size());
    // The two stacked boxes rest (and sink a little under their weight); the ball in the air
    // and the moving box are exactly as seeded.
    float ballLow = 1e9f, stackTop = 0.f, seededStackTop = 0.f;
    int moving = 0;
    for (std::size_t i = 0; i < settled->particles.size(); ++i) {
        const Vec3f& x = settled->particles.x[i];
        if (x[1] > 1.5f) ballLow = std::min(ballLow, x[1]);
        if (x[0] < 1.5f && x[1] < 1.0f) stackTop = std::max(stackTop, x[1]);
        if (settled->particles.v[i][0] == 1.f) ++moving;
        if (seeded->particles.x[i][0] < 1.5f && seeded->particles.x[i][1] < 1.0f)
            seededStackTop = std::max(seededStackTop, seeded->particles.x[i][1]);
    }
    float seededBallLow = 1e9f;
    for (const Vec3f& x : seeded->particles.x)
        if (x[1] > 1.5f) seededBallLow = std::min(seededBallLow, x[1]);
    CHECK(ballLow == seededBallLow);
    CHECK(stackTop < seededStackTop); // compressed under gravity
    CHECK(stackTop > seededStackTop - 0.01f);
    CHECK(moving > 0);
}

TEST_CASE("Settling reports a static load beyond the strength, and where", "[settle]") {
    // A weak layer with 300 Pa of compressive strength under a 0.4 m slab (~1 kPa): overloaded.
    std::string text = slabOnSlope(0.0, true);
    text.replace(text.find("initial_p0 = 3350.0"), 19, "initial_p0 = 300.0");
    auto w = buildWorld(test::sceneFromText(text));
    INFO(w->settle.message);
    CHECK(w->settle.overloaded > 100);
    CHECK(w->settle.message.find("static load beyond their strength") != std::string::npos);
    CHECK(w->settle.message.find(" of weak)") != std::string::npos); // named as in the scene
    CHECK(w->settle.overloadedMin[1] >= -0.01);
    CHECK(w->settle.overloadedMax[1] <= 0.1); // in the weak layer, not the slab
    // Counted per material: all of them in the weak layer (material 2) or the slab over it.
    REQUIRE(w->settle.overloadedByMaterial.size() == 2);
    CHECK(w->settle.overloadedByMaterial[1] > 100);
    CHECK(w->settle.overloadedByMaterial[0] + w->settle.overloadedByMaterial[1] ==
          w->settle.overloaded);

    // A scene in a local frame (a DEM's, SceneDesc::frameOrigin) reports the box in the scene's
    // coordinates, as every other output does: the same run, shifted by the origin.
    SceneDesc shifted = test::sceneFromText(text);
    shifted.frameOrigin = {2.6e6, 1500.0, 0.0};
    auto far = buildWorld(shifted);
    CHECK(far->settle.overloaded == w->settle.overloaded);
    CHECK(far->settle.overloadedMin[0] == w->settle.overloadedMin[0] + 2.6e6);
    CHECK(far->settle.overloadedMax[1] == w->settle.overloadedMax[1] + 1500.0);
    CHECK(far->settle.message.find("x in [2.6e+06") != std::string::npos);
}

TEST_CASE("Settling does not depend on the scene's transfer", "[settle]") {
    // The static equilibrium does not depend on the transfer, so settling always uses APIC: with
    // FLIP the particles keep velocities the grid does not see, whose kinetic energy grows
    // without a peak after each reset and delays the next one (the 3D slope: 6 912 steps against
    // 2 236), and PIC's damping turns the slowest mode into a slow creep. The same column with
    // each transfer settles to bitwise the same state in the same steps, and the scene's transfer
    // is back for the run.
    auto settleWith = [](Transfer transfer) {
        SceneDesc scene = test::sceneFromText(slabOnSlope(0.0, true));
        scene.grid.transfer = transfer;
        scene.grid.flipRelaxationTime = 1.0;
        return buildWorld(scene);
    };
    auto apic = settleWith(Transfer::Apic);
    for (const Transfer transfer : {Transfer::Flip, Transfer::Pic}) {
        auto w = settleWith(transfer);
        INFO("transfer " << int(transfer) << ": " << w->settle.steps << " steps, APIC "
                         << apic->settle.steps);
        CHECK(w->transfer == transfer);
        CHECK(w->settle.steps == apic->settle.steps);
        REQUIRE(w->particles.size() == apic->particles.size());
        std::size_t differ = 0;
        for (std::size_t i = 0; i < w->particles.size(); ++i)
            differ += w->particles.x[i] != apic->particles.x[i] ||
                      w->particles.tau[i].xy != apic->particles.tau[i].xy;
        CHECK(differ == 0);
    }
}

TEST_CASE("Settling steps at its own CFL number to the state the scene's would reach", "[settle]") {
    // The derived number: the stability study's largest CFL stable for APIC at every density,
    // never below the scene's; simulation.settle_cfl as given.
    CHECK(settlingCfl(0.0, 0.4) == 0.7);
    CHECK(settlingCfl(0.0, 1.2) == 1.2);
    CHECK(settlingCfl(0.3, 0.4) == 0.3);

    // The column settled at the scene's CFL (0.4) and at the derived one (0.7): the same
    // particles overloaded, in fewer steps, and the run then steps at the scene's CFL again. The
    // discrete equilibrium itself moves a little with the step: 1.17e-5 m between CFL 0.4 and
    // 0.7 (1.36e-5 m at 1.0), 3 % of the 3.9e-4 m that settling moves the particles, 0.04 %
    // of dx, and the same at settle_tolerance 1e-6, 1e-8 and 1e-10 (measured): a property of
    // the fixed point, not of when the relaxation stops. 5 % of the settling displacement
    // bounds it. 410 steps against 750 at 0.4 (measured).
    auto settleAt = [](double settleCfl) {
        SceneDesc scene = test::sceneFromText(slabOnSlope(0.0, true));
        scene.simulation.settleCfl = settleCfl;
        return buildWorld(scene);
    };
    auto slow = settleAt(0.4);
    auto fast = settleAt(0.0);
    INFO("settling steps " << slow->settle.steps << " at CFL 0.4, " << fast->settle.steps
                           << " at 0.7");
    REQUIRE(slow->settle.converged);
    REQUIRE(fast->settle.converged);
    CHECK(fast->settle.steps < slow->settle.steps * 2 / 3);
    CHECK(fast->cfl == slow->cfl);
    CHECK(fast->cfl == 0.4f);
    CHECK(fast->settle.overloaded == slow->settle.overloaded);
    REQUIRE(fast->particles.size() == slow->particles.size());
    auto seeded = buildWorld(test::sceneFromText(slabOnSlope(0.0, true)), BuildStage::Seeded);
    float largest = 0.f, settledBy = 0.f;
    for (std::size_t i = 0; i < fast->particles.size(); ++i) {
        largest = std::max(largest, (fast->particles.x[i] - slow->particles.x[i]).norm());
        settledBy = std::max(settledBy, (slow->particles.x[i] - seeded->particles.x[i]).norm());
    }
    INFO("largest difference in position " << largest << " m; settling moved particles by up to "
                                           << settledBy << " m");
    CHECK(largest < 0.05f * settledBy);
}
