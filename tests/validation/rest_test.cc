// A body at rest must not gain energy: an elastic PST column (scenes/pst.toml with elastic slab
// and weak layer, a sticky floor and a 0.2 m cut) settles under a 0.1 s gravity ramp and then
// rests for 1 s. Before Fe was stored as H = Fe - I (ParticleSet::H), the per-step strain
// increments of resting snow rounded away and the column gained energy every step (APIC at
// CFL 0.1: +70 % of its elastic energy at dx 0.04) while the overhang kept sinking.
#include "test_util.h"

#include <firn/diagnostics.h>

#include <catch2/catch.hpp>

#include <cmath>
#include <string>

using namespace firn;

namespace {

constexpr double kSettled = 0.15; // s: after the 0.1 s gravity ramp and its first rebound
constexpr double kRestEnd = kSettled + 1.0;
/// The deflection is compared from here on, once the ringing left by the ramp has decayed.
constexpr double kRinging = 0.35; // s
/// The overhang's deflection is averaged over windows of this length: the column keeps ringing
/// (APIC and FLIP hardly damp it) and a window spans many periods of its vertical mode.
constexpr double kWindow = 0.2;   // s
constexpr double kSample = 0.002; // s
constexpr int kSlabMaterial = 0;  // the scene's first [[material]]

/// The column: 0.5 m elastic slab (E 5 MPa) on a 6 cm elastic layer (G 0.2 MPa), 0.8 m long,
/// with the layer cut away under its first 0.2 m. Sleeping is off: it would freeze the column
/// and hide what the integrator does.
std::unique_ptr<World> restingColumn(const std::string& transfer, double cfl, double dx) {
    const std::string text = R"([simulation]
name = "rest"
dimension = 2
end_time = 1.15
gravity = [0.0, -9.81]
gravity_ramp = 0.1
[grid]
particles_per_cell = 4
sleep = false
dx = )" + std::to_string(dx) +
                             "\ncfl = " + std::to_string(cfl) + "\ntransfer = \"" + transfer + R"("
[[material]]
name = "slab"
model = "elastic"
density = 250.0
youngs_modulus = 5.0e6
poisson_ratio = 0.2
[[material]]
name = "weak"
model = "elastic"
density = 100.0
youngs_modulus = 4.8e5
poisson_ratio = 0.2
[[terrain]]
shape = "plane"
point = [0.0, 0.0]
normal = [0.0, 1.0]
boundary = "sticky"
[[body]]
name = "weak"
material = "weak"
shape = "layer"
on_top_of = "ground"
thickness = 0.06
x_range = [0.0, 0.8]
[[body]]
name = "slab"
material = "slab"
shape = "layer"
on_top_of = "weak"
thickness = 0.5
x_range = [0.0, 0.8]
[[cut]]
layer = "weak"
from_x = 0.0
length = 0.2
)";
    return buildWorld(test::sceneFromText(text, "rest"));
}

/// Mean height of the slab's particles in [from, to) along x, m.
double slabHeight(const World& world, double from, double to) {
    const ParticleSet& ps = world.particles;
    double sum = 0, mass = 0;
    for (std::size_t i = 0; i < ps.size(); ++i)
        if (ps.material[i] == kSlabMaterial && ps.x[i][0] >= from && ps.x[i][0] < to)
            sum += ps.mass[i] * ps.x[i][1], mass += ps.mass[i];
    return sum / mass;
}

/// The overhang's bending: how much higher the supported slab (beyond 0.5 m) stands than the
/// free end (the first 0.05 m), m. Relative, so that the squeeze of the layer under the whole
/// slab, which a 6 cm layer at dx 0.04 resolves poorly, drops out.
double freeEndDrop(const World& world) {
    return slabHeight(world, 0.5, 0.8) - slabHeight(world, 0.0, 0.05);
}

struct RestRun {
    double elasticEnergy = 0;   ///< J, when settled
    double energyGain = 0;      ///< J, drift at the end minus drift when settled
    double deflectionEarly = 0; ///< m, free end's deflection, mean over [kRinging, + kWindow]
    double deflectionLate = 0;  ///< m, the same over the last window
};

/// Time-mean of the free end's deflection (its drop now minus at the start) over
/// [from, from + kWindow].
double meanDeflection(World& world, double initialDrop, double from) {
    double sum = 0;
    int n = 0;
    for (double t = from + kSample; t <= from + kWindow + 1e-9; t += kSample, ++n) {
        test::advanceTo(world, t);
        sum += freeEndDrop(world) - initialDrop;
    }
    return sum / n;
}

/// Runs the column to kRestEnd (or only through the early window when `end` is earlier).
RestRun rest(const std::string& transfer, double cfl, double dx, double end = kRestEnd) {
    auto world = restingColumn(transfer, cfl, dx);
    const double initialDrop = freeEndDrop(*world);
    const StabilityWatch watch(computeDiagnostics(*world), *world);
    test::advanceTo(*world, kSettled);
    RestRun r;
    const FrameDiagnostics settled = computeDiagnostics(*world);
    r.elasticEnergy = settled.elasticEnergy;
    test::advanceTo(*world, kRinging);
    r.deflectionEarly = meanDeflection(*world, initialDrop, kRinging);
    if (end < kRestEnd) return r;
    test::advanceTo(*world, kRestEnd - kWindow);
    r.deflectionLate = meanDeflection(*world, initialDrop, kRestEnd - kWindow);
    r.energyGain = watch.drift(computeDiagnostics(*world)) - watch.drift(settled);
    return r;
}

} // namespace

TEST_CASE("A column at rest gains no energy, for every transfer and CFL", "[validation][rest]") {
    // The extreme CFLs (the error was per step: CFL 0.1 made the most steps) and each transfer,
    // at dx 0.04 to keep CI short (the gain before the fix was half that at dx 0.02, still
    // +70 % for APIC at CFL 0.1).
    const auto [transfer, cfl] =
        GENERATE(std::make_pair(std::string("apic"), 0.1), std::make_pair(std::string("apic"), 0.8),
                 std::make_pair(std::string("pic"), 0.8), std::make_pair(std::string("flip"), 0.1));
    const RestRun r = rest(transfer, cfl, 0.04);
    INFO(transfer << " CFL " << cfl << ": elastic energy " << r.elasticEnergy
                  << " J, energy gained over 1 s at rest " << r.energyGain << " J ("
                  << 100 * r.energyGain / r.elasticEnergy << " %)");
    // The issue's bound: a 1 s rest may change the total energy by 3 % of the elastic energy.
    // Dissipation (PIC damps the ringing of the settled column) is allowed; a gain is not.
    CHECK(r.energyGain < 0.03 * r.elasticEnergy);
}

TEST_CASE("The overhang of a column at rest is stationary", "[validation][rest]") {
    // dx 0.02: at dx 0.04 the 6 cm layer is 1.5 cells and the 0.2 m overhang 5, too coarse to
    // bend (its free end stands higher than the supported slab).
    const RestRun r = rest("apic", 0.4, 0.02);
    INFO("free end sinks " << r.deflectionEarly << " m after settling, " << r.deflectionLate
                           << " m 0.6 s later; energy gained "
                           << 100 * r.energyGain / r.elasticEnergy << " %");
    REQUIRE(r.deflectionEarly > 0);
    // Stationary to 2 % (the issue's bound); the window means leave a ringing residue well
    // under that.
    CHECK(std::abs(r.deflectionLate - r.deflectionEarly) < 0.02 * r.deflectionEarly);
    CHECK(r.energyGain < 0.03 * r.elasticEnergy);
}

TEST_CASE("The overhang's deflection at rest converges with dx", "[validation][rest]") {
    // The free end's settled deflection (mean over [kRinging, kRinging + kWindow]) at dx 0.02
    // and 0.01: before Fe was stored as H it crept, and at dx 0.01 (more steps) it sank 14 %
    // further than at dx 0.02 over the same time.
    const RestRun coarse = rest("apic", 0.4, 0.02, kRinging + kWindow);
    const RestRun fine = rest("apic", 0.4, 0.01, kRinging + kWindow);
    INFO("free end sinks " << coarse.deflectionEarly << " m at dx 0.02, " << fine.deflectionEarly
                           << " m at dx 0.01");
    REQUIRE(fine.deflectionEarly > 0);
    // Measured 0.568 and 0.563 mm (1 %); 5 % leaves room for the spline's first-order
    // error at the cut's corner while catching any per-step creep (14 % before the fix).
    CHECK(std::abs(fine.deflectionEarly - coarse.deflectionEarly) < 0.05 * fine.deflectionEarly);
}
