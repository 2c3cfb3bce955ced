// validation.md V1 (sliding block), V2 (P-wave speed), V5 (free fall).
#include "test_util.h"

#include <firn/diagnostics.h>

#include <Eigen/Dense>

#include <catch2/catch.hpp>

#include <cmath>

using namespace firn;

namespace {

constexpr double kG = 9.81;
constexpr double kPi = 3.14159265358979323846;

std::string elasticMaterial(double E, double nu, double rho) {
    return "[[material]]\nname = \"block\"\nmodel = \"elastic\"\ndensity = " + std::to_string(rho) +
           "\nyoungs_modulus = " + std::to_string(E) + "\npoisson_ratio = " + std::to_string(nu) +
           "\n";
}

/// Distance travelled along the slope direction (cos th, -sin th) by the centre of mass,
/// sampled every 0.05 s over [0.2, 1] s, then the fitted acceleration.
double slideAcceleration(World& world, double theta, bool tiltedGravity) {
    const Eigen::Vector3d down = tiltedGravity
                                     ? Eigen::Vector3d(1, 0, 0)
                                     : Eigen::Vector3d(std::cos(theta), -std::sin(theta), 0);
    const Eigen::Vector3d c0 = computeDiagnostics(world).centreOfMass;
    std::vector<double> t, s;
    for (int k = 4; k <= 20; ++k) {
        test::advanceTo(world, 0.05 * k);
        t.push_back(world.time);
        s.push_back((computeDiagnostics(world).centreOfMass - c0).dot(down));
    }
    return test::fitAcceleration(t, s);
}

/// A stiff elastic block on a Coulomb floor: either a flat floor under tilted gravity, or an
/// inclined plane under vertical gravity with the block as a layer draped on it.
std::unique_ptr<World> slidingBlock(double thetaDeg, double mu, bool tiltedGravity) {
    const double th = thetaDeg * kPi / 180;
    // A stiff block, settled by a 0.1 s gravity ramp: without it the block bounces on its
    // elastic base and the contact force, and so the friction, oscillates.
    std::string text =
        "[simulation]\nname = \"slide\"\ndimension = 2\nend_time = 1.0\ngravity_ramp = 0.1\n";
    if (tiltedGravity) {
        text += "gravity = [" + std::to_string(kG * std::sin(th)) + ", " +
                std::to_string(-kG * std::cos(th)) + "]\n";
        text += "[[terrain]]\nshape = \"plane\"\npoint = [0.0, 0.0]\nnormal = [0.0, 1.0]\n";
        text += "boundary = \"friction\"\nfriction = " + std::to_string(mu) + "\n";
        text += "[[body]]\nmaterial = \"block\"\nshape = \"box\"\nmin = [0.0, 0.0]\nmax = [1.0, "
                "0.25]\n";
    } else {
        text += "[[terrain]]\nshape = \"plane\"\npoint = [0.0, 0.0]\nnormal = [" +
                std::to_string(std::sin(th)) + ", " + std::to_string(std::cos(th)) + "]\n";
        text += "boundary = \"friction\"\nfriction = " + std::to_string(mu) + "\n";
        text += "[[body]]\nmaterial = \"block\"\nshape = \"layer\"\nthickness = 0.25\n"
                "x_range = [0.0, 0.9]\n";
    }
    text += "[grid]\ndx = 0.05\nparticles_per_cell = 4\ncfl = 0.4\n";
    text += elasticMaterial(1.0e7, 0.3, 1000.0);
    return buildWorld(test::sceneFromText(text, "slide"));
}

} // namespace

TEST_CASE("V5 free fall follows the symplectic Euler parabola to float rounding", "[validation]") {
    for (const char* dimText : {"2", "3"}) {
        const bool d3 = dimText[0] == '3';
        const std::string text =
            std::string("[simulation]\nname = \"fall\"\ndimension = ") + dimText +
            "\nend_time = 0.5\ngravity = " + (d3 ? "[0.0, -9.81, 0.0]" : "[0.0, -9.81]") +
            "\n[grid]\ndx = 0.1\nparticles_per_cell = " + (d3 ? "8" : "4") +
            "\ncfl = 10.0\nmax_dt = 0.005\n" + elasticMaterial(1.0e3, 0.3, 100.0) +
            "[[body]]\nmaterial = \"block\"\nshape = \"box\"\nmin = " +
            (d3 ? "[0.0, 1.0, 0.0]\nmax = [0.4, 1.3, 0.3]\n" : "[0.0, 1.0]\nmax = [0.4, 1.3]\n");
        auto world = buildWorld(test::sceneFromText(text, "fall"));
        const std::vector<Vec3f> x0 = world->particles.x; // bucketing keeps the order at rest
        const double dt = 0.005;
        const int n = 100;
        REQUIRE(stableTimeStep(*world) == Approx(dt)); // cfl 10 leaves max_dt in charge
        // Bucket order changes as particles cross leaves: compare the sorted heights.
        std::vector<float> y0;
        for (const Vec3f& p : x0) y0.push_back(p[1]);
        for (int s = 0; s < n; ++s) step(*world, dt);
        std::vector<float> y;
        for (const Vec3f& p : world->particles.x) y.push_back(p[1]);
        std::sort(y0.begin(), y0.end());
        std::sort(y.begin(), y.end());
        // Symplectic Euler: v_k = k g dt, x_n = x_0 - g dt^2 n (n + 1) / 2 exactly.
        const double t = n * dt;
        const double discrete = 0.5 * kG * dt * dt * n * (n + 1);
        for (std::size_t i = 0; i < y.size(); ++i) {
            // Float positions near 1 m after 100 additions: 2e-5 m covers the rounding.
            REQUIRE(double(y0[i]) - y[i] == Approx(discrete).margin(2e-5));
        }
        // The continuous parabola differs by exactly g t dt / 2, the scheme's O(dt) offset.
        REQUIRE(discrete - 0.5 * kG * t * t == Approx(0.5 * kG * t * dt));
    }
}

TEST_CASE("V1 a block slides with a = g (sin th - mu cos th)", "[validation]") {
    struct Case {
        double thetaDeg, mu, expected;
    };
    // validation.md V1: 4.0554 and 0.6571 m/s^2.
    for (const Case c : {Case{30, 0.1, 4.0554}, Case{30, 0.5, 0.6571}}) {
        for (bool tilted : {true, false}) {
            auto world = slidingBlock(c.thetaDeg, c.mu, tilted);
            test::advanceTo(*world, 0.1);
            const double a = slideAcceleration(*world, c.thetaDeg * kPi / 180, tilted);
            INFO("theta " << c.thetaDeg << " mu " << c.mu
                          << (tilted ? " tilted gravity" : " inclined plane") << ": a = " << a
                          << ", expected " << c.expected);
            // validation.md allows 3 % and says 1 % is achievable; we measure < 0.2 % with a
            // stiff block settled by a 0.1 s gravity ramp, so we hold the 1 % line.
            REQUIRE(a == Approx(c.expected).epsilon(0.01));
        }
    }
}

TEST_CASE("V1 a block sticks when tan th <= mu", "[validation]") {
    auto world = slidingBlock(25, 0.5, true);
    test::advanceTo(*world, 0.1);
    const Eigen::Vector3d c0 = computeDiagnostics(*world).centreOfMass;
    test::advanceTo(*world, 1.0);
    const double slip = computeDiagnostics(*world).centreOfMass[0] - c0[0];
    INFO("creep after 1 s: " << slip << " m");
    // validation.md V1: displacement after 1 s below 1e-3 dx.
    REQUIRE(std::abs(slip) < 1e-3 * 0.05);
}

TEST_CASE("V2 an elastic P-wave crosses a confined column at c_p", "[validation]") {
    // Snow slab of validation.md: E 5 MPa, nu 0.25, rho 250 -> c_p = 154.92 m/s. Slip walls above
    // and below make the strain uniaxial, so the wave front travels at c_p.
    const double cp = 154.92;
    const std::string text =
        "[simulation]\nname = \"wave\"\ndimension = 2\nend_time = 1.0\ngravity = [0.0, 0.0]\n"
        "[grid]\ndx = 0.01\nparticles_per_cell = 4\ncfl = 0.3\n" +
        elasticMaterial(5.0e6, 0.25, 250.0) +
        "[[terrain]]\nshape = \"plane\"\npoint = [0.0, 0.0]\nnormal = [0.0, 1.0]\nboundary = "
        "\"slip\"\n"
        "[[terrain]]\nshape = \"plane\"\npoint = [0.0, 0.05]\nnormal = [0.0, -1.0]\nboundary = "
        "\"slip\"\n"
        "[[body]]\nmaterial = \"block\"\nshape = \"box\"\nmin = [0.0, 0.0]\nmax = [0.1, 0.05]\n"
        "velocity = [0.1, 0.0]\n"
        "[[body]]\nmaterial = \"block\"\nshape = \"box\"\nmin = [0.1, 0.0]\nmax = [2.6, 0.05]\n";
    auto world = buildWorld(test::sceneFromText(text, "wave"));
    const double probes[2] = {0.6, 1.6}; // 1 m apart, past the 10-cell pulse
    double arrival[2] = {-1, -1};
    std::vector<std::vector<std::pair<double, double>>> history(2);
    while (world->time < 0.012) {
        const double dt = stableTimeStep(*world);
        step(*world, dt);
        for (int k = 0; k < 2; ++k) {
            double mv = 0, m = 0;
            const ParticleSet& ps = world->particles;
            for (std::size_t i = 0; i < ps.size(); ++i)
                if (std::abs(ps.x[i][0] - probes[k]) < 0.01)
                    mv += ps.mass[i] * ps.v[i][0], m += ps.mass[i];
            history[k].push_back({world->time, mv / m});
        }
    }
    // Half-amplitude arrival: the first time the probe velocity reaches half its peak,
    // interpolated linearly between steps.
    for (int k = 0; k < 2; ++k) {
        double peak = 0;
        for (auto [t, v] : history[k]) peak = std::max(peak, v);
        REQUIRE(peak > 0.02); // the pulse (amplitude ~ v0 / 2 = 0.05 m/s) arrived
        for (std::size_t s = 1; s < history[k].size() && arrival[k] < 0; ++s) {
            const auto [t0, v0] = history[k][s - 1];
            const auto [t1, v1] = history[k][s];
            if (v1 >= 0.5 * peak) arrival[k] = t0 + (t1 - t0) * (0.5 * peak - v0) / (v1 - v0);
        }
    }
    const double c = (probes[1] - probes[0]) / (arrival[1] - arrival[0]);
    INFO("measured c = " << c << " m/s, c_p = " << cp);
    // validation.md V2: 5 % at >= 10 cells per pulse width (here 10 cells).
    REQUIRE(c == Approx(cp).epsilon(0.05));
}
