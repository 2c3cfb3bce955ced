// validation.md V3 (axial vibration of a bar) and V4 (elastic column under its own weight).
//
// Particles change order whenever they change leaf (ParticleSet::bucketByLeaf), and carry no
// identity. Both cases deform along one axis only (nu = 0 between rollers), which keeps the
// particles' order along that axis, so a particle's reference coordinate is the one of the same
// rank among the sorted initial coordinates.
#include "test_util.h"

#include <firn/diagnostics.h>

#include <Eigen/Dense>

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

using namespace firn;

namespace {

constexpr double kPi = 3.14159265358979323846;

/// Particle indices ordered by coordinate `axis` (ties by index, so the order is deterministic).
std::vector<std::size_t> orderAlong(const ParticleSet& ps, int axis) {
    std::vector<std::size_t> order(ps.size());
    std::iota(order.begin(), order.end(), std::size_t(0));
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return ps.x[a][axis] < ps.x[b][axis]; });
    return order;
}

std::vector<double> sortedCoordinates(const ParticleSet& ps, int axis) {
    std::vector<double> c;
    for (std::size_t i : orderAlong(ps, axis)) c.push_back(ps.x[i][axis]);
    return c;
}

// ---------------------------------------------------------------------------------------------
// V3: a bar fixed at x = 0, free at x = L, between rollers, vibrating in its first mode
// u(x, t) = (v0 / w) sin(pi x / 2L) sin(w t), w = pi c / 2L, c = sqrt(E / rho) = 10 m/s.

constexpr double kBarLength = 25.0;     // m, L
constexpr double kBarSpeed0 = 0.1;      // m/s, v0
constexpr double kBarPeriod = 10.000;   // s, 4 L / c
constexpr double kBarPeakTip = 0.15916; // m, v0 / w

struct BarResult {
    double period = 0;          ///< s, from the tip's zero crossings
    int crossings = 0;          ///< zero crossings used
    double peakTip = 0;         ///< m, largest |u_tip| over the first period
    double energyDrift = 0;     ///< (E(end) - E(0)) / E(0)
    double maxEnergyChange = 0; ///< max |E(t) - E(0)| / E(0) over the run
};

/// Seeding: a regular lattice (jitter 0). The default jitter (0.5 of a sub-cell) makes the
/// stress quadrature irregular; on this bar (4 particles per cell, dx 0.5) it costs 39 % (APIC)
/// and 41 % (FLIP) of the energy over 10 periods and lengthens the period by 1.3 %, against
/// 0.2 % energy and 0.4 % period on the lattice, at any dx (the error is per particle, not per
/// cell). Measured with the sticky wall's nodes zeroed; with their mirror the lattice gives
/// 0.19 % and 0.012 % (APIC, dx 0.5).
BarResult vibrateBar(const std::string& transfer, double dx, int periods) {
    const std::string h = std::to_string(2 * dx); // two cells between the rollers
    const std::string text =
        "[simulation]\nname = \"bar\"\ndimension = 2\nend_time = 100.0\ngravity = [0.0, 0.0]\n"
        "[grid]\ndx = " +
        std::to_string(dx) +
        "\nparticles_per_cell = 4\njitter = 0.0\n"
        "cfl = 0.4\nmax_dt = 1.0\nsleep = false\ntransfer = \"" +
        transfer +
        "\"\n"
        "[[material]]\nname = \"bar\"\nmodel = \"elastic\"\ndensity = 1.0\n"
        "youngs_modulus = 100.0\npoisson_ratio = 0.0\n"
        // The fixed end: a sticky wall at x = 0.
        "[[terrain]]\nshape = \"plane\"\npoint = [0.0, 0.0]\nnormal = [1.0, 0.0]\n"
        "boundary = \"sticky\"\n"
        // Rollers: slip walls below and above.
        "[[terrain]]\nshape = \"plane\"\npoint = [0.0, 0.0]\nnormal = [0.0, 1.0]\n"
        "boundary = \"slip\"\n"
        "[[terrain]]\nshape = \"plane\"\npoint = [0.0, " +
        h +
        "]\nnormal = [0.0, -1.0]\n"
        "boundary = \"slip\"\n"
        "[[body]]\nmaterial = \"bar\"\nshape = \"box\"\nmin = [0.0, 0.0]\nmax = [25.0, " +
        h + "]\n";
    auto world = buildWorld(test::sceneFromText(text, "bar"));
    ParticleSet& ps = world->particles;
    // The scene format gives a body one uniform velocity: the mode shape v0 sin(pi x / 2L) is
    // set here, with its gradient as the affine matrix C (what APIC would carry for it).
    const double k = kPi / (2 * kBarLength);
    for (std::size_t i = 0; i < ps.size(); ++i) {
        const double x = ps.x[i][0];
        ps.v[i] = Vec3f(float(kBarSpeed0 * std::sin(k * x)), 0.f, 0.f);
        ps.C[i].setZero();
        ps.C[i](0, 0) = float(kBarSpeed0 * k * std::cos(k * x));
    }
    world->maxSpeed = float(kBarSpeed0);

    // The tip: the particles of the last half cell, found by rank along x.
    const std::vector<double> x0 = sortedCoordinates(ps, 0);
    const std::size_t tipCount =
        std::size_t(x0.end() - std::upper_bound(x0.begin(), x0.end(), kBarLength - 0.5 * dx));
    REQUIRE(tipCount > 0);
    auto tipMean = [&](const std::vector<double>& sorted) {
        return std::accumulate(sorted.end() - tipCount, sorted.end(), 0.0) / double(tipCount);
    };
    const double tip0 = tipMean(x0);

    const double endTime = periods * kBarPeriod;
    const double energy0 = computeDiagnostics(*world).totalEnergy();
    BarResult r;
    double firstCrossing = -1, lastCrossing = -1, uPrev = 0, tPrev = 0;
    while (world->time < endTime - 1e-9) {
        step(*world, std::min(stableTimeStep(*world), endTime - world->time));
        const double u = tipMean(sortedCoordinates(ps, 0)) - tip0;
        const double t = world->time;
        if (t <= kBarPeriod) r.peakTip = std::max(r.peakTip, std::abs(u));
        // Zero crossings after the first quarter period (u starts at 0), interpolated linearly.
        if (t > 0.25 * kBarPeriod && (uPrev < 0) != (u < 0)) {
            const double crossing = tPrev + (t - tPrev) * uPrev / (uPrev - u);
            if (firstCrossing < 0) firstCrossing = crossing;
            lastCrossing = crossing;
            ++r.crossings;
        }
        uPrev = u, tPrev = t;
        const double e = computeDiagnostics(*world).totalEnergy();
        r.maxEnergyChange = std::max(r.maxEnergyChange, std::abs(e - energy0) / energy0);
        r.energyDrift = (e - energy0) / energy0;
    }
    // Consecutive crossings are half a period apart.
    r.period = 2 * (lastCrossing - firstCrossing) / std::max(1, r.crossings - 1);
    return r;
}

// ---------------------------------------------------------------------------------------------
// V4: a column of height l0 between rollers on a fixed base, loaded by its own weight. In static
// equilibrium the Cauchy stress carries the weight above: sigma_yy(y0) = -rho g (l0 - y0), with
// y0 the reference height, whatever the constitutive law (Wyser et al. 2020, GMD 13:6265).

constexpr double kColumnHeight = 10.0;  // m, l0
constexpr double kColumnModulus = 1e4;  // Pa
constexpr double kColumnDensity = 80.0; // kg/m^3
constexpr double kG = 9.81;             // m/s^2
constexpr double kGravityRamp = 72.0;   // s
/// Averaging window after the ramp. The linear ramp leaves a free oscillation of relative
/// amplitude up to T / (pi t_ramp) ~ 2 % (T ~ 4 s, the column's first period); its mean over
/// 28 s (~7 periods) is the static state to ~0.1 %.
constexpr double kAverageFrom = 72.0, kAverageTo = 100.0; // s

/// Exact final height of the Hencky column (nu = 0, plane strain): the stretch lambda(y0)
/// solves E ln(lambda) / lambda = -rho g (l0 - y0) (Cauchy = Kirchhoff / J, J = lambda), and
/// the height is the integral of lambda over y0 (midpoint rule, bisection per point).
double exactColumnHeight() {
    const int n = 2000;
    double height = 0;
    for (int s = 0; s < n; ++s) {
        const double y0 = (s + 0.5) * kColumnHeight / n;
        const double target = -kColumnDensity * kG * (kColumnHeight - y0) / kColumnModulus;
        double lo = 1e-3, hi = 1.0; // ln(l) / l increases on (0, e)
        for (int it = 0; it < 60; ++it) {
            const double mid = 0.5 * (lo + hi);
            (std::log(mid) / mid < target ? lo : hi) = mid;
        }
        height += 0.5 * (lo + hi) * kColumnHeight / n;
    }
    return height;
}

struct ColumnResult {
    double l1Error = 0;     ///< mass-weighted relative L1 error of the time-averaged sigma_yy
    double l1ErrorBulk = 0; ///< the same above the first 2 m of reference height
    double height = 0;      ///< m, time-averaged top surface
};

/// Seeding: a regular lattice (jitter 0). With the default jitter the particles' stresses
/// scatter by ~15 % about the exact line (the irregular quadrature lets particles shear and
/// strain laterally by ~3 %), which swamps the discretisation error (L1 11-13 % at 10-40 cells).
ColumnResult loadColumn(const std::string& transfer, int cellsOverHeight) {
    const double dx = kColumnHeight / cellsOverHeight;
    const std::string w = std::to_string(2 * dx); // two cells between the rollers
    const std::string text =
        "[simulation]\nname = \"column\"\ndimension = 2\nend_time = 100.0\n"
        "gravity = [0.0, -9.81]\ngravity_ramp = 72.0\n"
        "[grid]\ndx = " +
        std::to_string(dx) +
        "\nparticles_per_cell = 4\njitter = 0.0\n"
        "cfl = 0.4\nmax_dt = 1.0\nsleep = false\ntransfer = \"" +
        transfer +
        "\"\n"
        "[[material]]\nname = \"column\"\nmodel = \"elastic\"\ndensity = 80.0\n"
        "youngs_modulus = 1.0e4\npoisson_ratio = 0.0\n"
        // The fixed base: a sticky floor.
        "[[terrain]]\nshape = \"plane\"\npoint = [0.0, 0.0]\nnormal = [0.0, 1.0]\n"
        "boundary = \"sticky\"\n"
        // Rollers: slip walls left and right.
        "[[terrain]]\nshape = \"plane\"\npoint = [0.0, 0.0]\nnormal = [1.0, 0.0]\n"
        "boundary = \"slip\"\n"
        "[[terrain]]\nshape = \"plane\"\npoint = [" +
        w +
        ", 0.0]\nnormal = [-1.0, 0.0]\n"
        "boundary = \"slip\"\n"
        "[[body]]\nmaterial = \"column\"\nshape = \"box\"\nmin = [0.0, 0.0]\nmax = [" +
        w + ", 10.0]\n";
    auto world = buildWorld(test::sceneFromText(text, "column"));
    REQUIRE(world->gravityRamp == float(kGravityRamp));
    // Reference heights, by rank (see the top of the file).
    const std::vector<double> y0 = sortedCoordinates(world->particles, 1);
    test::advanceTo(*world, kAverageFrom);

    // Time averages per rank of sigma_yy and of the top particle's height.
    std::vector<double> sigmaSum(y0.size(), 0.0);
    double topSum = 0, timeSum = 0;
    const ParticleSet& ps = world->particles;
    while (world->time < kAverageTo - 1e-9) {
        const double dt = std::min(stableTimeStep(*world), kAverageTo - world->time);
        step(*world, dt);
        const std::vector<std::size_t> order = orderAlong(ps, 1);
        for (std::size_t rank = 0; rank < order.size(); ++rank) {
            const std::size_t i = order[rank];
            // Cauchy stress sigma = tau / J from the Kirchhoff stress the particle stores.
            const double J = ps.deformationGradient(i).topLeftCorner<2, 2>().determinant();
            sigmaSum[rank] += dt * ps.stress(i).yy / J;
        }
        topSum += dt * ps.x[order.back()][1];
        timeSum += dt;
    }
    ColumnResult r;
    double error = 0, norm = 0, errorBulk = 0, normBulk = 0;
    const double particleMass = ps.mass[0]; // all particles alike: uniform lattice, one material
    for (std::size_t rank = 0; rank < y0.size(); ++rank) {
        const double exact = -kColumnDensity * kG * (kColumnHeight - y0[rank]);
        const double e = particleMass * std::abs(sigmaSum[rank] / timeSum - exact);
        const double n = particleMass * std::abs(exact);
        error += e, norm += n;
        if (y0[rank] > 2.0) errorBulk += e, normBulk += n;
    }
    r.l1Error = error / norm;
    r.l1ErrorBulk = errorBulk / normBulk;
    // Near the top the stretch is ~1: the surface lies l0 - y0 above the top particle.
    r.height = topSum / timeSum + (kColumnHeight - y0.back());
    return r;
}

} // namespace

TEST_CASE("V3 bar vibration: period, amplitude and energy of the first mode",
          "[validation][elastic]") {
    // dx 0.25: 100 cells along the bar, 400 per wavelength. The period's error is set by the
    // fixed end: with the sticky wall's nodes zeroed it moved the bar's effective root by ~0.2 dx
    // (APIC period +0.74 %, +0.36 %, +0.19 % at dx 1, 0.5, 0.25). The wall as a constraint on
    // the B-spline basis (firn/sticky_walls.h) gives +0.041 %, +0.012 %, +0.005 %.
    const double dx = 0.25;
    struct Case {
        const char* transfer;
        double energyTolerance;
    };
    // validation.md V3: energy drift < 1 % over 10 periods (APIC: measured -0.087 %). FLIP's
    // 0.95 blend keeps 5 % of PIC's damping: measured -3.2 %, held to 5 %. XPIC(2) damps what
    // its one round trip leaves of PIC's smoothing and keeps no particle noise: -0.72 %, V3's 1 %.
    for (const Case c : {Case{"apic", 0.01}, Case{"flip", 0.05}, Case{"xpic", 0.01}}) {
        const BarResult r = vibrateBar(c.transfer, dx, 10);
        INFO(c.transfer << " dx " << dx << ": period " << r.period << " s over " << r.crossings
                        << " zero crossings, peak tip " << r.peakTip << " m, energy drift "
                        << r.energyDrift << " (largest change " << r.maxEnergyChange << ")");
        REQUIRE(r.crossings >= 11); // >= 5 periods between the first and last crossing
        // validation.md V3: period within 0.5 % of 10.000 s (measured +0.005 %, both
        // transfers). The sticky wall's treatment is held to 0.05 %: zeroed nodes gave +0.19 %.
        REQUIRE(r.period == Approx(kBarPeriod).epsilon(0.005));
        REQUIRE(r.period == Approx(kBarPeriod).epsilon(0.0005));
        // Peak tip displacement v0 / w: it follows the period (w), so the same 0.5 %.
        REQUIRE(r.peakTip == Approx(kBarPeakTip).epsilon(0.005));
        REQUIRE(std::abs(r.energyDrift) < c.energyTolerance);
    }
}

TEST_CASE("V4 column under its own weight: sigma_yy = -rho g (l0 - y0)", "[validation][elastic]") {
    const double exactHeight = exactColumnHeight(); // 7.6556 m; the base stretch is 0.616
    std::vector<ColumnResult> results;
    for (int cells : {10, 20, 40}) results.push_back(loadColumn("apic", cells));
    for (std::size_t k = 0; k < results.size(); ++k) {
        const ColumnResult& r = results[k];
        INFO((10 << k) << " cells: L1 error " << r.l1Error << " (above 2 m: " << r.l1ErrorBulk
                       << "), height " << r.height << " m, exact " << exactHeight << " m");
        // The column's height: measured +0.0020, +0.00077, +0.00012 m from the exact (Hencky)
        // height, 0.002, 0.0015, 0.0005 dx; held to 0.005 dx. With the sticky base's nodes
        // zeroed the base sank: -0.056 to -0.058 dx.
        REQUIRE(std::abs(r.height - exactHeight) < 0.005 * kColumnHeight / (10 << k));
        // Away from the base the stress is exact to the quadrature and the averaging (see
        // kAverageFrom): measured 0.65, 0.30, 0.22 % above y0 = 2 m; 1 % at every resolution.
        REQUIRE(r.l1ErrorBulk < 0.01);
    }
    // validation.md V4: 2 % at 20 cells. Measured 0.93, 0.35, 0.22 % at 10, 20, 40 cells with
    // the sticky base as a constraint on the B-spline basis (firn/sticky_walls.h); zeroing the
    // base's nodes gave 6.1, 3.1, 1.6 %, nearly all of it in the 1.5 cells above the base.
    REQUIRE(results[1].l1Error < 0.02);
    // First order from 10 to 20 cells (measured ratio 2.65); at 40 cells the whole error is
    // the bulk's (0.220 % against 0.219 % above 2 m: the base no longer counts), which falls
    // more slowly, so only a decrease is asked there (measured ratio 1.59).
    REQUIRE(results[0].l1Error / results[1].l1Error > 1.8);
    REQUIRE(results[2].l1Error < results[1].l1Error);
}
