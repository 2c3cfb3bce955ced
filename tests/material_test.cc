// Single-point tests of the constitutive models: Hencky elasticity, the Cam-Clay invariants and
// yield surface, and the snow and weak-layer return mappings (validation.md V6; snow-model.md).
// The granular model has its own file, granular_test.cc.
//
// Loading paths are coaxial (fixed principal axes), so the elastic log strain after a step is
// simply eps_elastic + d_eps: the trial strain of the next return mapping.
#include <firn/material.h>
#include <firn/svd.h>

#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <vector>

using namespace firn;

namespace {

/// E = 1 MPa, nu = 0.25 gives mu = lambda = 4e5 Pa exactly: easy hand computations.
MaterialDesc roundDesc(MaterialModel model) {
    MaterialDesc desc;
    desc.model = model;
    desc.density = 300.0;
    desc.youngsModulus = 1.0e6;
    desc.poissonRatio = 0.25;
    return desc;
}

/// The scene-format defaults (E = 1 MPa, nu = 0.3, M = 1, beta = 0.3, xi = 5, p0 = 20 kPa,
/// alpha = 1, M_d = 1.2) for the model.
Material defaultMaterial(MaterialModel model, int dim) {
    MaterialDesc desc;
    desc.model = model;
    return Material::fromDesc(desc, dim);
}

float bulk(const Material& m) {
    return m.lame.bulkModulus(m.dim);
}

float p0Of(const Material& m, const PlasticState& s) {
    return camClayP0(bulk(m), m.camClay.xi, s.hardening);
}

StressInvariants invariantsOf(const Material& m, const Vec3f& eps) {
    return stressInvariants(kirchhoffPrincipal(m.lame, eps, m.dim), m.dim);
}

/// A unit traceless direction over the d active entries (third entry 0 in 2D).
Vec3f deviatoricDirection(int dim, float angle = 0.3f) {
    if (dim == 2) return Vec3f(1.f, -1.f, 0.f) / std::sqrt(2.f);
    // Lode-angle family: any unit vector orthogonal to (1,1,1).
    const Vec3f a = Vec3f(1.f, -1.f, 0.f) / std::sqrt(2.f);
    const Vec3f b = Vec3f(1.f, 1.f, -2.f) / std::sqrt(6.f);
    return std::cos(angle) * a + std::sin(angle) * b;
}

/// The principal Hencky strain with invariants (p, q) along a deviatoric direction, inverting
/// p = -K tr(eps), q = sqrt(3/2) 2 mu |dev(eps)|.
Vec3f strainFor(const Material& m, float p, float q, const Vec3f& devDir) {
    const int d = m.dim;
    Vec3f eps = devDir * (q / (std::sqrt(1.5f) * 2.f * m.lame.mu));
    for (int i = 0; i < d; ++i) eps[i] += -p / (bulk(m) * float(d));
    return eps;
}

/// q on the Cam-Clay surface at pressure p: the root of eq. (1), validation.md V6.
float yieldQ(float p, float p0, float M, float beta) {
    return M * std::sqrt(std::max((p + beta * p0) * (p0 - p), 0.f) / (1.f + 2.f * beta));
}

float traceOf(const Vec3f& eps, int dim) {
    float tr = 0.f;
    for (int i = 0; i < dim; ++i) tr += eps[i];
    return tr;
}

/// Isotropic strain increment of volume change dV (tr = dV over the d active entries).
Vec3f isotropic(int dim, float dV) {
    Vec3f e = Vec3f::Zero();
    for (int i = 0; i < dim; ++i) e[i] = dV / float(dim);
    return e;
}

} // namespace

// ---------------------------------------------------------------------------------------------
// Parameters and elasticity

TEST_CASE("Lame parameters from Young's modulus and Poisson's ratio", "[material]") {
    // mu = E / (2 (1 + nu)), lambda = E nu / ((1 + nu)(1 - 2 nu)); exact in float up to 1 ulp.
    const Lame lame = Lame::fromYoungPoisson(1.0e6, 0.25);
    CHECK(lame.mu == Approx(4.0e5).epsilon(1e-7));
    CHECK(lame.lambda == Approx(4.0e5).epsilon(1e-7));
    CHECK(lame.bulkModulus(3) == Approx(4.0e5 + 8.0e5 / 3.0).epsilon(1e-7));
    CHECK(lame.bulkModulus(2) == Approx(8.0e5).epsilon(1e-7));
}

TEST_CASE("Material::fromDesc copies every parameter", "[material]") {
    MaterialDesc desc;
    desc.model = MaterialModel::WeakLayer;
    desc.density = 150.0;
    desc.criticalStateSlope = 1.1;
    desc.cohesionRatio = 0.2;
    desc.initialP0 = 1.5e3;
    desc.hardening = 1.6;
    desc.softening = 0.1;
    desc.dynamicCriticalStateSlope = 1.4;
    desc.frictionAngle = 35.0;
    desc.dynamicFrictionAngle = 50.0;
    desc.grainDiameter = 0.004;
    desc.inertialNumberScale = 0.5;
    const Material m = Material::fromDesc(desc, 2);
    CHECK(m.model == MaterialModel::WeakLayer);
    CHECK(m.dim == 2);
    CHECK(m.density == 150.f);
    CHECK(m.camClay.M == 1.1f);
    CHECK(m.camClay.beta == 0.2f);
    CHECK(m.camClay.p0Initial == 1.5e3f);
    CHECK(m.camClay.xi == 1.6f);
    CHECK(m.camClay.alpha == 0.1f);
    CHECK(m.camClay.Md == 1.4f);
    CHECK(m.frictionAngleDeg == 35.f);
    CHECK(m.dynamicFrictionAngleDeg == 50.f);
    CHECK(m.grainDiameter == 0.004f);
    CHECK(m.inertialNumberScale == 0.5f);
    CHECK_FALSE(m.rateDependent()); // mu(I) is the granular model's only
}

TEST_CASE("P-wave speed", "[material]") {
    // sqrt((lambda + 2 mu) / rho) = sqrt(1.2e6 / 300) = sqrt(4000) = 63.2456 m/s; float: 1e-6.
    const Material m = Material::fromDesc(roundDesc(MaterialModel::Elastic), 3);
    CHECK(m.pWaveSpeed() == Approx(std::sqrt(4000.0)).epsilon(1e-6));
}

TEST_CASE("Hencky stress and energy at one point, by hand", "[material]") {
    // mu = lambda = 4e5 Pa. Tolerance 1e-6 relative: a handful of float operations on values
    // known to 7 digits.
    const Lame lame = Lame::fromYoungPoisson(1.0e6, 0.25);
    SECTION("3D") {
        // eps = (0.01, -0.02, 0.005), tr = -0.005, lambda tr = -2000 Pa
        // tau = 2 mu eps + lambda tr = (8000 - 2000, -16000 - 2000, 4000 - 2000)
        //     = (6000, -18000, 2000) Pa
        // p = -(6000 - 18000 + 2000) / 3 = 3333.33 Pa
        // s = tau + p = (9333.33, -14666.67, 5333.33), s:s = 3.306667e8, q = sqrt(1.5 s:s)
        //   = sqrt(4.96e8) = 22271.05 Pa
        // energy = mu |eps|^2 + lambda/2 tr^2 = 4e5 * 5.25e-4 + 2e5 * 2.5e-5 = 210 + 5 = 215
        const Vec3f eps(0.01f, -0.02f, 0.005f);
        const Vec3f tau = kirchhoffPrincipal(lame, eps, 3);
        CHECK(tau[0] == Approx(6000.0).epsilon(1e-6));
        CHECK(tau[1] == Approx(-18000.0).epsilon(1e-6));
        CHECK(tau[2] == Approx(2000.0).epsilon(1e-6));
        const StressInvariants inv = stressInvariants(tau, 3);
        CHECK(inv.p == Approx(10000.0 / 3.0).epsilon(1e-6));
        CHECK(inv.q == Approx(std::sqrt(4.96e8)).epsilon(1e-6));
        CHECK(henckyEnergy(lame, eps, 3) == Approx(215.0).epsilon(1e-6));
    }
    SECTION("2D ignores the third entry") {
        // eps = (0.01, -0.02), tr = -0.01: tau = (8000 - 4000, -16000 - 4000) = (4000, -20000)
        // p = 8000, s = (12000, -12000), s:s = 2.88e8, q = sqrt(4.32e8) = 20784.61 Pa
        // energy = 4e5 * 5e-4 + 2e5 * 1e-4 = 200 + 20 = 220
        const Vec3f eps(0.01f, -0.02f, 0.7f); // 0.7 must not matter
        const Vec3f tau = kirchhoffPrincipal(lame, eps, 2);
        CHECK(tau[0] == Approx(4000.0).epsilon(1e-6));
        CHECK(tau[1] == Approx(-20000.0).epsilon(1e-6));
        CHECK(tau[2] == 0.f);
        const StressInvariants inv = stressInvariants(tau, 2);
        CHECK(inv.p == Approx(8000.0).epsilon(1e-6));
        CHECK(inv.q == Approx(std::sqrt(4.32e8)).epsilon(1e-6));
        CHECK(henckyEnergy(lame, eps, 2) == Approx(220.0).epsilon(1e-6));
    }
}

TEST_CASE("Invariants from strain: p = -K tr(eps), q = sqrt(3/2) 2 mu |dev eps|", "[material]") {
    // The identity the return mappings rely on; float round-off only: 1e-5 relative.
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(-0.05f, 0.05f);
    const Lame lame = Lame::fromYoungPoisson(5.0e6, 0.3);
    for (int dim : {2, 3}) {
        for (int k = 0; k < 200; ++k) {
            Vec3f eps(u(rng), u(rng), dim == 3 ? u(rng) : 0.f);
            const StressInvariants inv = stressInvariants(kirchhoffPrincipal(lame, eps, dim), dim);
            const float tr = traceOf(eps, dim);
            Vec3f dev = eps;
            for (int i = 0; i < dim; ++i) dev[i] -= tr / float(dim);
            const float scale = lame.bulkModulus(dim) * eps.norm();
            CHECK(std::abs(inv.p + lame.bulkModulus(dim) * tr) <= 1e-5f * scale);
            CHECK(std::abs(inv.q - std::sqrt(1.5f) * 2.f * lame.mu * dev.norm()) <= 1e-5f * scale);
        }
    }
}

TEST_CASE("Cam-Clay yield surface: tips and peak (V6 closed forms)", "[material][camclay]") {
    const float p0 = 2.0e4f, M = 1.f, beta = 0.3f;
    const float tol = 1e-6f * p0 * p0; // y is O(p0^2); float round-off ~1e-7 of that
    // Tips: y(-beta p0, 0) = y(p0, 0) = 0.
    CHECK(std::abs(camClayYield(-beta * p0, 0.f, p0, M, beta)) <= tol);
    CHECK(std::abs(camClayYield(p0, 0.f, p0, M, beta)) <= tol);
    // Peak q_max = M p0 (1 + beta) / (2 sqrt(1 + 2 beta)) at p_c = p0 (1 - beta) / 2.
    const float pc = p0 * (1.f - beta) / 2.f;
    const float qMax = M * p0 * (1.f + beta) / (2.f * std::sqrt(1.f + 2.f * beta));
    CHECK(std::abs(camClayYield(pc, qMax, p0, M, beta)) <= tol);
    CHECK(camClayYield(pc, 1.001f * qMax, p0, M, beta) > 0.f);
    CHECK(camClayYield(pc, 0.999f * qMax, p0, M, beta) < 0.f);
    // ... and it is the top of the ellipse: at any other p, (p, q_max) is outside.
    for (float p = -beta * p0; p <= p0; p += 0.01f * p0)
        if (std::abs(p - pc) > 0.02f * p0) CHECK(camClayYield(p, qMax, p0, M, beta) > 0.f);
}

TEST_CASE("Cam-Clay strength used: 1 on the surface, scaling with the stress, 0 at rest",
          "[material][camclay]") {
    const double p0 = 3450.0, M = 1.0, beta = 0.1;
    // Points of eq. (1) around the ellipse, q = M sqrt((p + beta p0)(p0 - p) / (1 + 2 beta)):
    // each uses the whole strength, and a stress scaled by s from one uses s of it (the ray
    // through it leaves the surface once; round-off of double: 1e-12).
    for (double p = -beta * p0; p <= p0; p += 0.05 * p0) {
        const double q = M * std::sqrt(std::max((p + beta * p0) * (p0 - p), 0.0) / (1 + 2 * beta));
        CHECK(camClayStrengthUsed(p, q, p0, M, beta) == Approx(1.0).epsilon(1e-12));
        for (double scale : {0.25, 0.8, 1.5})
            CHECK(camClayStrengthUsed(scale * p, scale * q, p0, M, beta) ==
                  Approx(scale).epsilon(1e-12));
    }
    CHECK(camClayStrengthUsed(0.0, 0.0, p0, M, beta) == 0.0);
    // No strength left to use: a collapsed layer (p0 = 0) under stress, tension without cohesion.
    CHECK(std::isinf(camClayStrengthUsed(100.0, 50.0, 0.0, M, beta)));
    CHECK(std::isinf(camClayStrengthUsed(-100.0, 0.0, p0, M, 0.0)));
    // Compression without cohesion still has strength: the tip (p0, 0) uses all of it.
    CHECK(camClayStrengthUsed(p0, 0.0, p0, M, 0.0) == Approx(1.0).epsilon(1e-12));
}

TEST_CASE("Hardening law eq. (2) and the initial state", "[material][camclay]") {
    for (MaterialModel model : {MaterialModel::Snow, MaterialModel::WeakLayer}) {
        for (int dim : {2, 3}) {
            const Material m = defaultMaterial(model, dim);
            const PlasticState s = m.initialState();
            // p0 = initial_p0 through eq. (2): the float offset is good to ~1e-7 relative, and
            // sinh is linear here, so p0 to 1e-5.
            CHECK(s.hardening < 0.f);
            CHECK(p0Of(m, s) == Approx(m.camClay.p0Initial).epsilon(1e-5));
            CHECK(s.epsV == 0.f);
            CHECK(s.eta == 0.f);
            CHECK(s.flags == 0u);
        }
    }
    const Material g = defaultMaterial(MaterialModel::Granular, 3);
    CHECK(g.initialState().hardening == 0.f);
    // Dilated states have no strength; huge compaction stays finite.
    CHECK(camClayP0(1e6f, 5.f, 0.01f) == 0.f);
    CHECK(camClayP0(1e6f, 5.f, 0.f) == 0.f);
    CHECK(std::isfinite(camClayP0(1e9f, 50.f, -100.f)));
}

// ---------------------------------------------------------------------------------------------
// Cam-Clay return mapping (snow), V6. Every test runs in 2D and 3D.

TEST_CASE("Cam-Clay: states inside the surface stay elastic", "[material][camclay]") {
    for (int dim : {2, 3}) {
        INFO("dim = " << dim);
        const Material m = defaultMaterial(MaterialModel::Snow, dim);
        const PlasticState s0 = m.initialState();
        const float p0 = p0Of(m, s0), M = m.camClay.M, beta = m.camClay.beta;
        std::mt19937 rng(11 + dim);
        std::uniform_real_distribution<float> up(-beta * p0, p0), uf(0.f, 0.999f), ua(0.f, 6.3f);
        for (int k = 0; k < 1000; ++k) {
            const float p = up(rng);
            const float q = uf(rng) * yieldQ(p, p0, M, beta);
            const Vec3f eps = strainFor(m, p, q, deviatoricDirection(dim, ua(rng)));
            if (camClayYield(p, q, p0, M, beta) > -1e-4f * p0 * p0) continue; // too close to call
            const ReturnMapResult r = returnMapCamClay(m, eps, s0);
            CHECK(r.eps == eps);
            CHECK(r.state.hardening == s0.hardening);
            CHECK(r.state.epsV == 0.f);
            CHECK(r.state.flags == 0u);
        }
    }
}

TEST_CASE("Cam-Clay: shear at constant p yields at q_y(p)", "[material][camclay]") {
    for (int dim : {2, 3}) {
        INFO("dim = " << dim);
        const Material m = defaultMaterial(MaterialModel::Snow, dim);
        const PlasticState s0 = m.initialState();
        const float p0 = p0Of(m, s0), M = m.camClay.M, beta = m.camClay.beta;
        for (float f = -0.95f; f <= 0.951f; f += 0.05f) {
            // p across the open interval (-beta p0, p0).
            const float p = 0.5f * (1.f - beta) * p0 + f * 0.5f * (1.f + beta) * p0;
            const float qy = yieldQ(p, p0, M, beta);
            INFO("p = " << p << ", q_y = " << qy);
            // Just inside: elastic.
            const Vec3f inside = strainFor(m, p, 0.99f * qy, deviatoricDirection(dim));
            CHECK(returnMapCamClay(m, inside, s0).state.flags == 0u);
            // Outside: p kept, q brought to q_y, flagged. Tolerances 1e-5 p0: float round-off of
            // strains ~p0/K rebuilt from (p, q).
            const float qTrial = 1.5f * qy + 0.1f * p0;
            const Vec3f trial = strainFor(m, p, qTrial, deviatoricDirection(dim));
            const ReturnMapResult r = returnMapCamClay(m, trial, s0);
            const StressInvariants inv = invariantsOf(m, r.eps);
            CHECK(std::abs(inv.p - p) <= 1e-5f * p0);
            CHECK(std::abs(inv.q - qy) <= 1e-5f * p0);
            // The hardening variable moves by the ray-to-centre increment (snow-model.md), here
            // from the closed form p_x of the spec: d eps_V^P = (p_x - p_trial) / K.
            const float pc = 0.5f * (1.f - beta) * p0;
            const float dp = p - pc, norm = std::hypot(dp, qTrial);
            const float dpUnit = dp / norm, dqUnit = qTrial / norm;
            const float px = pc + dpUnit * M * (1.f + beta) * p0 /
                                      (2.f * std::sqrt((1.f + 2.f * beta) * dqUnit * dqUnit +
                                                       M * M * dpUnit * dpUnit));
            const float dEps = (px - p) / bulk(m);
            // The increment is ~p0/K ~ 1e-2; its float error ~1e-7 of the hardening variable.
            CHECK(r.state.epsV == Approx(dEps).margin(1e-6 * std::abs(s0.hardening)));
            CHECK(r.state.hardening - s0.hardening ==
                  Approx(dEps).margin(1e-6 * std::abs(s0.hardening)));
            // Tension side of the centre dilates (softens), compression side compacts (hardens).
            if (dp < -0.01f * p0) CHECK(dEps > 0.f);
            if (dp > 0.01f * p0) CHECK(dEps < 0.f);
            CHECK(r.state.flags == kFlagFailed);
            // Still the same deviatoric direction.
            const Vec3f dev = strainFor(m, 0.f, 1.f, deviatoricDirection(dim));
            Vec3f devNew = r.eps - isotropic(dim, traceOf(r.eps, dim));
            CHECK(devNew.normalized().dot(dev.normalized()) == Approx(1.f).epsilon(1e-5));
        }
        // At the centre p_c the returned q is the peak q_max of V6.
        const float pc = p0 * (1.f - beta) / 2.f;
        const float qMax = M * p0 * (1.f + beta) / (2.f * std::sqrt(1.f + 2.f * beta));
        const ReturnMapResult r =
            returnMapCamClay(m, strainFor(m, pc, 3.f * qMax, deviatoricDirection(dim)), s0);
        CHECK(invariantsOf(m, r.eps).q == Approx(qMax).epsilon(1e-5));
    }
}

TEST_CASE("Cam-Clay: tips", "[material][camclay]") {
    for (int dim : {2, 3}) {
        INFO("dim = " << dim);
        const Material m = defaultMaterial(MaterialModel::Snow, dim);
        const PlasticState s0 = m.initialState();
        const float p0 = p0Of(m, s0), beta = m.camClay.beta;
        // Tolerance 1e-5 p0: float round-off of an isotropic strain ~p0/K.
        SECTION("compressive tip, with and without shear") {
            for (float q : {0.f, 0.3f * p0, 3.f * p0}) {
                const ReturnMapResult r =
                    returnMapCamClay(m, strainFor(m, 1.5f * p0, q, deviatoricDirection(dim)), s0);
                const StressInvariants inv = invariantsOf(m, r.eps);
                CHECK(std::abs(inv.p - p0) <= 1e-5f * p0);
                CHECK(inv.q <= 1e-5f * p0);
                CHECK(r.state.flags == kFlagFailed);
                // eps_V^P change = tr(trial) - tr(tip) = (-1.5 p0 + p0) / K < 0: compaction.
                CHECK(r.state.epsV == Approx(-0.5f * p0 / bulk(m)).epsilon(1e-4));
                CHECK(p0Of(m, r.state) > p0);
            }
        }
        SECTION("tensile tip, with and without shear") {
            for (float q : {0.f, 0.3f * p0, 3.f * p0}) {
                const ReturnMapResult r = returnMapCamClay(
                    m, strainFor(m, -2.f * beta * p0, q, deviatoricDirection(dim)), s0);
                const StressInvariants inv = invariantsOf(m, r.eps);
                CHECK(std::abs(inv.p + beta * p0) <= 1e-5f * p0);
                CHECK(inv.q <= 1e-5f * p0);
                CHECK(r.state.flags == kFlagFailed);
                CHECK(r.state.epsV == Approx(beta * p0 / bulk(m)).epsilon(1e-4)); // dilation
                CHECK(p0Of(m, r.state) < p0);                                     // softens
            }
        }
    }
}

TEST_CASE("Cam-Clay: after any return mapping the state is on or inside the surface",
          "[material][camclay]") {
    // V6: |y| <= 1e-5 p0^2 after a plastic return (y is O(p0^2) and carries float round-off of
    // p and q, ~1e-7 relative each), y <= 1e-5 p0^2 after an elastic one, and no plastic flow
    // for trial states inside. y is measured against the surface the state was projected onto,
    // i.e. p0 at the start of the step (hardening is explicit, as in the authors' codes).
    for (int dim : {2, 3}) {
        INFO("dim = " << dim);
        const Material m = defaultMaterial(MaterialModel::Snow, dim);
        const float M = m.camClay.M, beta = m.camClay.beta;
        std::mt19937 rng(1000 + dim);
        std::uniform_real_distribution<float> uh(-0.01f, -0.0001f), up(-2.f, 3.f), uq(0.f, 3.f),
            ua(0.f, 6.3f);
        int plastic = 0;
        for (int k = 0; k < 20000; ++k) {
            PlasticState s = m.initialState();
            s.hardening = uh(rng); // p0 from ~40 Pa to ~45 kPa
            const float p0 = p0Of(m, s);
            const Vec3f trial =
                strainFor(m, up(rng) * p0, uq(rng) * p0, deviatoricDirection(dim, ua(rng)));
            const StressInvariants in = invariantsOf(m, trial);
            const ReturnMapResult r = returnMapCamClay(m, trial, s);
            const StressInvariants out = invariantsOf(m, r.eps);
            const float y = camClayYield(out.p, out.q, p0, M, beta);
            INFO("p0 = " << p0 << ", trial (p, q) = (" << in.p << ", " << in.q << ")");
            if (r.state.flags & kFlagFailed) {
                ++plastic;
                CHECK(std::abs(y) <= 1e-5f * p0 * p0);
            } else {
                CHECK(y <= 1e-5f * p0 * p0);
                CHECK(r.eps == trial);
            }
            if (camClayYield(in.p, in.q, p0, M, beta) < -1e-4f * p0 * p0)
                CHECK((r.state.flags & kFlagFailed) == 0u);
            CHECK(std::isfinite(r.state.hardening));
        }
        CHECK(plastic > 5000); // the sample did exercise the plastic branches
    }
}

TEST_CASE("Cam-Clay: isotropic compression hardens along eq. (2), unloading is elastic",
          "[material][camclay]") {
    for (int dim : {2, 3}) {
        INFO("dim = " << dim);
        const Material m = defaultMaterial(MaterialModel::Snow, dim);
        const float K = bulk(m), xi = m.camClay.xi;
        PlasticState s = m.initialState();
        Vec3f eps = Vec3f::Zero();
        const float h0 = s.hardening;
        double totalVolume = 0.0;
        float p0Prev = p0Of(m, s);
        int yieldSteps = 0;
        for (int step = 0; step < 200; ++step) {
            const Vec3f dEps = isotropic(dim, -1e-3f); // tr(d eps) = -1e-3 per step
            totalVolume += traceOf(dEps, dim);
            const Vec3f trial = eps + dEps;
            const float p0Before = p0Of(m, s);
            const ReturnMapResult r = returnMapCamClay(m, trial, s);
            const StressInvariants inv = invariantsOf(m, r.eps);
            if (r.eps != trial) { // plastic in this step
                ++yieldSteps;
                CHECK(r.state.flags == kFlagFailed);
                // The state sits at the compressive tip of the surface it was projected on.
                CHECK(inv.p == Approx(p0Before).epsilon(1e-5));
                CHECK(inv.q <= 1e-5f * p0Before);
                const float p0 = p0Of(m, r.state);
                CHECK(p0 > p0Prev); // compaction hardens
                p0Prev = p0;
            } else {
                CHECK(inv.p <= p0Before); // elastic only while inside
            }
            // eps_V^P = h0 + (total volume - elastic volume) at all times. Tolerance 1e-6
            // absolute: ~200 float additions of O(1e-3) increments into |h| < 0.05 (ulp 4e-9).
            const double elasticVolume = traceOf(r.eps, dim);
            CHECK(r.state.hardening == Approx(h0 + totalVolume - elasticVolume).margin(1e-6));
            CHECK(r.state.epsV == Approx(r.state.hardening - h0).margin(1e-6));
            // p0 follows eq. (2) (same float expression: 1e-6 relative).
            CHECK(p0Of(m, r.state) ==
                  Approx(K * std::sinh(xi * std::max(-r.state.hardening, 0.f))).epsilon(1e-6));
            eps = r.eps;
            s = r.state;
        }
        CHECK(yieldSteps > 50);
        CHECK(p0Of(m, s) > 3.f * m.camClay.p0Initial);

        // Unloading: isotropic extension in small steps down to p = 0 is elastic and leaves
        // the plastic volume frozen.
        const PlasticState frozen = s;
        const float pStart = invariantsOf(m, eps).p;
        for (int step = 0; step < 10; ++step) {
            const Vec3f trial = eps + isotropic(dim, 0.1f * pStart / K);
            const ReturnMapResult r = returnMapCamClay(m, trial, s);
            CHECK(r.eps == trial);
            CHECK(r.state.hardening == frozen.hardening);
            CHECK(r.state.epsV == frozen.epsV);
            eps = r.eps;
            s = r.state;
        }
        CHECK(std::abs(invariantsOf(m, eps).p) <= 1e-4f * pStart);
    }
}

TEST_CASE("Cam-Clay: tension softens p0 to zero", "[material][camclay]") {
    for (int dim : {2, 3}) {
        INFO("dim = " << dim);
        const Material m = defaultMaterial(MaterialModel::Snow, dim);
        PlasticState s = m.initialState();
        Vec3f eps = Vec3f::Zero();
        float p0Prev = p0Of(m, s);
        bool yielded = false;
        for (int step = 0; step < 200 && p0Prev > 0.f; ++step) {
            const Vec3f trial = eps + isotropic(dim, 1e-3f);
            const ReturnMapResult r = returnMapCamClay(m, trial, s);
            if (r.eps != trial) { // plastic in this step
                yielded = true;
                // At the tensile tip of the surface it was projected on (1e-5 p0 as above).
                CHECK(std::abs(invariantsOf(m, r.eps).p + m.camClay.beta * p0Prev) <=
                      1e-5f * m.camClay.p0Initial);
                CHECK(r.state.epsV > s.epsV); // dilation
                const float p0 = p0Of(m, r.state);
                CHECK(p0 < p0Prev);
                p0Prev = p0;
            }
            eps = r.eps;
            s = r.state;
        }
        CHECK(yielded);
        CHECK(p0Prev == 0.f);
        CHECK(s.hardening >= 0.f);
        // With no strength left: zero stress under tension, and compaction hardens again.
        const ReturnMapResult t = returnMapCamClay(m, eps + isotropic(dim, 1e-3f), s);
        CHECK(t.eps.norm() == 0.f);
        PlasticState c = t.state;
        Vec3f e = t.eps;
        for (int step = 0; step < 50; ++step) {
            const ReturnMapResult r = returnMapCamClay(m, e + isotropic(dim, -2e-3f), c);
            CHECK(std::isfinite(r.eps.norm()));
            e = r.eps;
            c = r.state;
        }
        CHECK(p0Of(m, c) > 0.f);
    }
}

namespace {

/// Energy per unit volume (J/m^3) a 2D (plane strain) snow point takes in uniaxial tension
/// along x, the lateral stress held at zero, until its stress has fallen to 1e-3 of its peak;
/// and that peak (Pa). The elastic energy left at the end is nil, so all of it is dissipated.
std::pair<double, double> tensionToFailure(const Material& m) {
    PlasticState s = m.initialState();
    Vec3f eps = Vec3f::Zero();
    const float de = 2e-6f;
    double work = 0.0, peak = 0.0;
    for (int k = 0; k < 100000; ++k) {
        Vec3f trial = eps;
        trial[0] += de;
        ReturnMapResult r;
        Vec3f tau;
        for (int it = 0; it < 60; ++it) { // secant on the lateral strain: tau_yy = 0
            r = returnMap(m, trial, s);
            tau = kirchhoffPrincipal(m.lame, r.eps, 2);
            if (std::abs(tau[1]) < 1e-3f) break;
            trial[1] -= tau[1] / (m.lame.lambda + 2.f * m.lame.mu);
        }
        work += double(tau[0]) * de;
        peak = std::max(peak, double(tau[0]));
        eps = r.eps, s = r.state;
        if (tau[0] < 1e-3 * peak) return {work, peak};
    }
    return {work, peak};
}

} // namespace

TEST_CASE("A slab point broken in tension dissipates its peak elastic energy at xi 5, 4.4 times "
          "that at the table's xi 0.5",
          "[material][camclay]") {
    // The table's slab at 250 kg/m^3 (E 4.82 MPa, nu 0.2, M 1, beta 0.5, p0 22.44 kPa).
    // Brittle limit: the stress drops to zero at its peak, so the point dissipates the elastic
    // energy it held there, sigma^2 / 2E' with E' = E / (1 - nu^2) in plane strain. The
    // hardening factor xi sets how far past the peak softening (eq. 2) takes it: the
    // scenes/slope2d.toml header turns these into fracture energies per unit area (x the
    // band, one 5 cm cell: 2.4 against 0.56 J/m^2; snow's K_Ic^2 / E' is 0.05-0.2 J/m^2).
    MaterialDesc desc;
    desc.model = MaterialModel::Snow;
    desc.density = 250.0;
    desc.youngsModulus = 4.82e6;
    desc.poissonRatio = 0.2;
    desc.criticalStateSlope = 1.0;
    desc.cohesionRatio = 0.5;
    desc.initialP0 = 22440.0;
    const double stiffness = 4.82e6 / (1.0 - 0.2 * 0.2);
    const auto dissipatedOverBrittle = [&](double xi) {
        desc.hardening = xi;
        const auto [work, peak] = tensionToFailure(Material::fromDesc(desc, 2));
        INFO("xi " << xi << ": peak " << peak << " Pa, dissipated " << work << " J/m^3");
        CHECK(peak == Approx(10500.0).epsilon(0.01)); // xi does not change the strength
        return work / (peak * peak / (2.0 * stiffness));
    };
    // 1-2 %: the elastic energy is integrated in steps of 2e-6 strain (0.1 % of the peak
    // strain), and the last step before the drop yields a little.
    const double brittle = dissipatedOverBrittle(5.0);
    CHECK(brittle > 1.0);
    CHECK(brittle < 1.03);
    // The table's slab: the measured 4.43, within 5 %.
    CHECK(dissipatedOverBrittle(0.5) == Approx(4.43).epsilon(0.05));
}

// ---------------------------------------------------------------------------------------------
// Weak layer: softening with the anticrack strain (eqs. 3-4), then eq. (5).

namespace {

/// The PST weak layer of validation.md V6 / scenes/pst.toml: G 0.2 MPa (E 0.48 MPa, nu 0.2),
/// p0 3.45 kPa, beta 0.1, M 1 (shear strength 1 kPa), xi 0.015, alpha 100.
Material pstWeakLayer(int dim) {
    MaterialDesc desc;
    desc.model = MaterialModel::WeakLayer;
    desc.density = 100.0;
    desc.youngsModulus = 4.8e5;
    desc.poissonRatio = 0.2;
    desc.criticalStateSlope = 1.0;
    desc.cohesionRatio = 0.1;
    desc.initialP0 = 3450.0;
    desc.hardening = 0.015;
    desc.softening = 100.0;
    desc.dynamicCriticalStateSlope = 1.2;
    return Material::fromDesc(desc, dim);
}

/// One material point driven like a particle (F -> SVD -> log strain -> return mapping), in
/// simple shear (shear strain increments in the x-y plane) at a fixed normal stress
/// tau_yy = -sigmaN, held by a secant iteration on the normal stretch of each increment. x and
/// (in 3D) z are held fixed: a layer confined laterally, as a weak layer under a slab.
struct SimpleShearPoint {
    const Material& m;
    Eigen::Matrix3f F = Eigen::Matrix3f::Identity();
    PlasticState state;
    Eigen::Matrix3f tau = Eigen::Matrix3f::Zero();

    /// Trial F, return mapping and stress for a shear increment dGamma and normal strain dN.
    void evaluate(float dGamma, float dN, Eigen::Matrix3f& Fout, PlasticState& sOut,
                  Eigen::Matrix3f& tauOut) const {
        Eigen::Matrix3f L = Eigen::Matrix3f::Zero();
        L(0, 1) = dGamma;
        L(1, 1) = dN;
        const Eigen::Matrix3f Ftrial = (Eigen::Matrix3f::Identity() + L) * F;
        const LeftStretch ls = leftStretch(Ftrial, m.dim);
        Vec3f eps = Vec3f::Zero();
        for (int a = 0; a < m.dim; ++a) eps[a] = std::log(ls.sigma[a]);
        const ReturnMapResult r = returnMap(m, eps, state);
        Vec3f scale = Vec3f::Ones();
        for (int a = 0; a < m.dim; ++a) scale[a] = std::exp(r.eps[a]) / ls.sigma[a];
        Fout = ls.U * scale.asDiagonal() * ls.U.transpose() * Ftrial;
        sOut = r.state;
        tauOut = ls.U * kirchhoffPrincipal(m.lame, r.eps, m.dim).asDiagonal() * ls.U.transpose();
    }

    /// Applies dGamma with the normal stress held at -sigmaN (to 1e-4 sigmaN).
    void shear(float dGamma, float sigmaN) {
        Eigen::Matrix3f Fn, tn;
        PlasticState sn;
        const float stiffness = m.lame.lambda + 2.f * m.lame.mu; // oedometric, first guess
        float dN = 0.f;
        for (int it = 0; it < 60; ++it) {
            evaluate(dGamma, dN, Fn, sn, tn);
            const float residual = tn(1, 1) + sigmaN;
            if (std::abs(residual) <= 1e-4f * sigmaN) break;
            dN -= residual / stiffness;
        }
        F = Fn, state = sn, tau = tn;
    }
};

} // namespace

TEST_CASE("Weak layer in simple shear at 1 kPa normal stress softens to collapse (mixed mode)",
          "[material][weaklayer]") {
    // validation.md V6: sigma_n = 1 kPa under p0 = 3.45 kPa, beta 0.1, M 1. The confined
    // point sits at p ~ 0.6 kPa, below the centre p_c = 1.55 kPa, so shear yield dilates by the
    // ray-to-centre increment, eta grows by alpha |d eps_V^P| (eq. 4) and p0 falls (eq. 3) until
    // it reaches 0: collapse, eq. (5). Expected: collapse at a shear strain of the order of
    // the elastic one at yield (tau_p / G = 0.5 %), well before 5 %.
    for (int dim : {2, 3}) {
        INFO("dim = " << dim);
        const Material m = pstWeakLayer(dim);
        SimpleShearPoint point{m, Eigen::Matrix3f::Identity(), m.initialState(),
                               Eigen::Matrix3f::Zero()};
        const float K = m.lame.bulkModulus(dim), p0Start = p0Of(m, point.state);
        REQUIRE(p0Start == Approx(3450.f).epsilon(1e-5));
        float gamma = 0.f, peakShear = 0.f, gammaCollapse = -1.f;
        float p0Previous = p0Start;
        bool monotone = true;
        for (int k = 0; k < 500 && gammaCollapse < 0.f; ++k) {
            point.shear(1e-4f, 1000.f);
            gamma += 1e-4f;
            peakShear = std::max(peakShear, point.tau(0, 1));
            const float p0 = (point.state.flags & kFlagCollapsed)
                                 ? 0.f
                                 : camClayP0(K, m.camClay.xi, point.state.hardening);
            monotone = monotone && p0 <= p0Previous;
            p0Previous = p0;
            if (point.state.flags & kFlagCollapsed) gammaCollapse = gamma;
        }
        INFO("peak shear stress " << peakShear << " Pa, collapse at gamma = " << gammaCollapse);
        CHECK(monotone); // p0 only ever falls: softening, never hardening
        REQUIRE(gammaCollapse > 0.f);
        CHECK(gammaCollapse < 0.05f);
        // The shear peak is below the ellipse's q_max / sqrt(3) = tau_p = 1 kPa (the point
        // yields at p below p_c), and above half of it.
        CHECK(peakShear < 1000.f);
        CHECK(peakShear > 500.f);
        // After collapse the layer carries the normal load by friction and compaction (eq. 5):
        // the normal stress is held, and the shear stress is at most M_d-frictional.
        for (int k = 0; k < 50; ++k) point.shear(1e-4f, 1000.f);
        CHECK(point.tau(1, 1) == Approx(-1000.f).epsilon(1e-3));
        CHECK(point.state.eta == Approx(-m.initialState().hardening).epsilon(1e-6));
    }
}

TEST_CASE("Cam-Clay shear: above the centre p0 stays, below it softens, above it hardens",
          "[material][camclay][weaklayer]") {
    // snow-model.md, hardening increment: sheared repeatedly at constant p (each increment
    // pushes q past the surface again), a point at p_c keeps p0 (the ray is vertical), a slab
    // point below p_c softens (p0 falls), above p_c hardens (p0 rises); the weak layer keeps
    // p0 at p_c and softens on either side (|d eps_V^P|, eq. 4).
    for (int dim : {2, 3})
        for (const MaterialModel model : {MaterialModel::Snow, MaterialModel::WeakLayer}) {
            const Material m = model == MaterialModel::Snow
                                   ? defaultMaterial(MaterialModel::Snow, dim)
                                   : pstWeakLayer(dim);
            const float M = m.camClay.M, beta = m.camClay.beta;
            for (const float side : {-0.5f, 0.f, 0.5f}) {
                INFO("dim " << dim << ", model " << int(model) << ", p = p_c + " << side
                            << " (p0 (1 + beta) / 2)");
                PlasticState s = m.initialState();
                const float p0Start = p0Of(m, s);
                for (int k = 0; k < 20; ++k) {
                    const float p0 = p0Of(m, s);
                    const float pc = 0.5f * (1.f - beta) * p0;
                    const float p = pc + side * 0.5f * (1.f + beta) * p0;
                    const float qTrial = 1.2f * yieldQ(p, p0, M, beta);
                    s = returnMap(m, strainFor(m, p, qTrial, deviatoricDirection(dim)), s).state;
                    if (s.flags & kFlagCollapsed) break;
                }
                const float p0End = (s.flags & kFlagCollapsed) ? 0.f : p0Of(m, s);
                INFO("p0 " << p0Start << " -> " << p0End);
                CHECK(s.flags & kFlagFailed);
                if (side == 0.f) {
                    // Directly above the centre: no increment (float round-off of p - p_c ~
                    // 1e-7 p0 moves p0 by ~1e-7 relative per step).
                    CHECK(p0End == Approx(p0Start).epsilon(1e-5));
                    CHECK(s.eta == Approx(0.f).margin(1e-6));
                } else if (model == MaterialModel::WeakLayer || side < 0.f) {
                    CHECK(p0End < 0.9f * p0Start);
                } else {
                    CHECK(p0End > 1.01f * p0Start);
                }
            }
        }
}

TEST_CASE("Weak layer: compression softens to collapse, then compacts frictionally",
          "[material][weaklayer]") {
    // Under strain control the softening branch has slope dp/d(tr eps) ~ K (1 - 1/(alpha xi))
    // (small-strain form of eqs. 3-4): for alpha xi < 1 the layer softens gradually, for
    // alpha xi > 1 (the defaults: 1 x 5) it snaps back and collapses within a few steps.
    for (const float alpha : {0.1f, 1.f})
        for (int dim : {2, 3}) {
            INFO("dim = " << dim << ", alpha = " << alpha);
            Material m = defaultMaterial(MaterialModel::WeakLayer, dim);
            m.camClay.alpha = alpha;
            const PlasticState s0 = m.initialState();
            const float eta0 = s0.hardening;
            PlasticState s = s0;
            Vec3f eps = Vec3f::Zero();
            float p0Prev = p0Of(m, s);
            int step = 0, softeningSteps = 0;
            bool softening = false;
            // Compression at 2e-4 per step until collapse: p0 falls with eta, eq. (3).
            for (; step < 5000 && !(s.flags & kFlagCollapsed); ++step) {
                const ReturnMapResult r = returnMapWeakLayer(m, eps + isotropic(dim, -2e-4f), s);
                if (!softening) {
                    // Before the first yield: eta output exactly 0, no flags.
                    CHECK(s.eta == 0.f);
                    CHECK(s.flags == 0u);
                }
                if (r.state.flags & kFlagFailed) {
                    softening = true;
                    CHECK(r.state.eta > s.eta);   // anticrack strain grows
                    CHECK(r.state.epsV < s.epsV); // compaction
                    if (!(r.state.flags & kFlagCollapsed)) {
                        ++softeningSteps;
                        CHECK(p0Of(m, r.state) < p0Prev); // softening, eq. (3)
                        // eta output is eta - eta0 (float: 1e-5 of |eta0|)
                        CHECK(r.state.eta ==
                              Approx(r.state.hardening - eta0).margin(1e-5f * -eta0));
                        // d eta = alpha |d eps_V^P|, eq. (4). eta is a float of magnitude
                        // |eta0| ~ 5e-3 (ulp 5e-10), so tiny increments are quantised:
                        // 1e-4 relative plus 1e-6 |eta0| absolute.
                        CHECK(r.state.eta - s.eta ==
                              Approx(m.camClay.alpha * (s.epsV - r.state.epsV))
                                  .epsilon(1e-4)
                                  .margin(1e-6f * -eta0));
                        p0Prev = p0Of(m, r.state);
                    }
                }
                eps = r.eps;
                s = r.state;
            }
            REQUIRE((s.flags & kFlagCollapsed) != 0u);
            CHECK(softeningSteps >= (alpha * m.camClay.xi < 1.f ? 10 : 1));
            CHECK((s.flags & kFlagFailed) != 0u);
            CHECK(s.hardening == 0.f);                   // eps_V^P restarts at t_c
            CHECK(s.eta == Approx(-eta0).epsilon(1e-5)); // frozen at -eta0: p0 reached 0
            CHECK(p0Of(m, s) == 0.f);
            const float etaFrozen = s.eta;

            // Collapsed, p0 = 0, beta = 0: the surface is the origin; continued compression goes to
            // zero stress first, then compaction hardens p0 again by eq. (2).
            p0Prev = 0.f;
            for (int k = 0; k < 100; ++k) {
                const ReturnMapResult r = returnMapWeakLayer(m, eps + isotropic(dim, -2e-3f), s);
                const StressInvariants inv = invariantsOf(m, r.eps);
                CHECK(std::isfinite(inv.p));
                if ((r.state.flags & kFlagCollapsed) && r.state.epsV < s.epsV) {
                    CHECK(inv.p == Approx(p0Of(m, s)).margin(1e-5f * m.camClay.p0Initial));
                    CHECK(p0Of(m, r.state) > p0Prev);
                    p0Prev = p0Of(m, r.state);
                }
                CHECK(r.state.eta == etaFrozen); // eta is frozen after collapse
                eps = r.eps;
                s = r.state;
            }
            CHECK(p0Of(m, s) > 0.1f * m.camClay.p0Initial); // compacted, carries load again

            // Frictional surface of eq. (5): q_y = M_d sqrt(p (p0 - p)), no tensile strength.
            const float p0 = p0Of(m, s), Md = m.camClay.Md;
            for (float f : {0.1f, 0.3f, 0.5f, 0.8f}) {
                const float p = f * p0, qy = Md * std::sqrt(p * (p0 - p));
                const ReturnMapResult in =
                    returnMapWeakLayer(m, strainFor(m, p, 0.99f * qy, deviatoricDirection(dim)), s);
                CHECK(in.state.epsV == s.epsV);
                CHECK(in.state.hardening == s.hardening);
                const ReturnMapResult out =
                    returnMapWeakLayer(m, strainFor(m, p, 2.f * qy, deviatoricDirection(dim)), s);
                const StressInvariants inv = invariantsOf(m, out.eps);
                CHECK(std::abs(inv.p - p) <= 1e-5f * p0);
                CHECK(std::abs(inv.q - qy) <= 1e-5f * p0);
                CHECK(std::abs(inv.q * inv.q + Md * Md * (inv.p * inv.p - inv.p * p0)) <=
                      1e-5f * p0 * p0);
            }
            // Any tension: to the origin (beta = 0).
            const ReturnMapResult t = returnMapWeakLayer(
                m, strainFor(m, -0.1f * p0, 0.2f * p0, deviatoricDirection(dim)), s);
            CHECK(invariantsOf(m, t.eps).p == Approx(0.f).margin(1e-5f * p0));
            CHECK(invariantsOf(m, t.eps).q == Approx(0.f).margin(1e-5f * p0));
        }
}

TEST_CASE("Weak layer: elastic inside, failed flag and eta on first yield",
          "[material][weaklayer]") {
    for (int dim : {2, 3}) {
        INFO("dim = " << dim);
        const Material m = defaultMaterial(MaterialModel::WeakLayer, dim);
        const PlasticState s0 = m.initialState();
        const float p0 = p0Of(m, s0);
        // Inside: nothing changes.
        const Vec3f inside = strainFor(m, 0.5f * p0, 0.1f * p0, deviatoricDirection(dim));
        const ReturnMapResult r0 = returnMapWeakLayer(m, inside, s0);
        CHECK(r0.eps == inside);
        CHECK(r0.state.flags == 0u);
        CHECK(r0.state.eta == 0.f);
        // Shear yield at constant p off the centre (p_c = 0.35 p0 for beta 0.3): flagged and
        // softened by the ray-to-centre increment, eq. (4) (mixed mode).
        const Vec3f shear = strainFor(m, 0.5f * p0, 2.f * p0, deviatoricDirection(dim));
        const ReturnMapResult r1 = returnMapWeakLayer(m, shear, s0);
        CHECK(r1.state.flags == kFlagFailed);
        CHECK(r1.state.eta > 0.f);
        CHECK(p0Of(m, r1.state) < p0);
        // Tension past the tip also softens: any plastic volume change, eq. (4). (Not too far
        // past: a plastic volume change above |eta0| / alpha collapses the layer in one step.)
        const Vec3f tension = strainFor(m, -0.35f * p0, 0.f, deviatoricDirection(dim));
        const ReturnMapResult r2 = returnMapWeakLayer(m, tension, s0);
        CHECK(r2.state.flags == kFlagFailed);
        CHECK(r2.state.eta > 0.f);
        CHECK(r2.state.epsV > 0.f);
        CHECK(p0Of(m, r2.state) < p0);
        // Dispatch.
        const ReturnMapResult r3 = returnMap(m, tension, s0);
        CHECK(r3.eps == r2.eps);
        CHECK(r3.state.eta == r2.state.eta);
    }
}

TEST_CASE("Elastic material: returnMap leaves everything alone", "[material]") {
    const Material m = Material::fromDesc(roundDesc(MaterialModel::Elastic), 3);
    const Vec3f trial(0.3f, -0.2f, 0.5f);
    const ReturnMapResult r = returnMap(m, trial, m.initialState());
    CHECK(r.eps == trial);
    CHECK(r.state.flags == 0u);
    CHECK(r.state.hardening == 0.f);
}

TEST_CASE("Snow dispatch and a NaN trial stays NaN (no silent repair)", "[material][camclay]") {
    const Material m = defaultMaterial(MaterialModel::Snow, 3);
    const Vec3f trial = strainFor(m, 2.f * m.camClay.p0Initial, 0.f, deviatoricDirection(3));
    CHECK(returnMap(m, trial, m.initialState()).eps ==
          returnMapCamClay(m, trial, m.initialState()).eps);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const ReturnMapResult r = returnMapCamClay(m, Vec3f(nan, 0.f, 0.f), m.initialState());
    CHECK(std::isnan(r.eps[0]));
}

TEST_CASE("a snow particle counts as fractured once p0 has softened to half its start",
          "[material]") {
    Material snow;
    snow.model = MaterialModel::Snow;
    snow.dim = 2;
    snow.lame = Lame::fromYoungPoisson(5.0e6, 0.3);
    snow.camClay.p0Initial = 2000.f;
    const float K = snow.lame.bulkModulus(2), xi = snow.camClay.xi;
    // eq. (2) inverted: the hardening variable at which p0 = ratio * initial_p0
    const auto atRatio = [&](double ratio) {
        PlasticState s = snow.initialState();
        s.hardening = float(-std::asinh(ratio * 2000.0 / K) / xi);
        return s;
    };
    CHECK_FALSE(slabFractured(snow, snow.initialState()));
    CHECK_FALSE(slabFractured(snow, atRatio(0.55)));
    CHECK(slabFractured(snow, atRatio(0.45)));
    CHECK(slabFractured(snow, atRatio(0.0)));
    Material weak = snow;
    weak.model = MaterialModel::WeakLayer;
    CHECK_FALSE(slabFractured(weak, atRatio(0.0))); // the weak layer is no slab
}

TEST_CASE("Weak layer softening: the crack band scales alpha with the cell size below its length",
          "[material][weaklayer]") {
    // alpha * min(1, 6 dx / length): the band of 6 cells (kCrackBandCells) dissipates per unit
    // area in proportion to its thickness over alpha, so a band half as thick needs half the
    // alpha to dissipate what the calibrated layer did. Exact arithmetic.
    CHECK(kCrackBandCells == 6.0);
    CHECK(crackBandSoftening(100.0, 0.06, 0.01) == Approx(100.0).epsilon(1e-12));
    CHECK(crackBandSoftening(100.0, 0.06, 0.005) == Approx(50.0).epsilon(1e-12));
    CHECK(crackBandSoftening(100.0, 0.06, 0.0075) == Approx(75.0).epsilon(1e-12));
    CHECK(crackBandSoftening(100.0, 0.06, 0.05) == 100.0);  // a band thicker than the length
    CHECK(crackBandSoftening(100.0, 0.0, 0.0075) == 100.0); // no length: off
    CHECK(crackBandSoftening(100.0, 0.06, 0.0) == 100.0);   // a single point

    // The coarse side, reported by `firn check` and not applied: a 0.2 m layer at dx 0.05 (its
    // band: the whole layer, below 6 dx = 0.3 m) with the table's alpha 100 dissipates
    // 0.2 / 0.06 = 3.33 times the calibrated layer's energy per area; alpha 333 matches it.
    CHECK(collapseBandThickness(0.2, 0.05) == Approx(0.2).epsilon(1e-12));
    CHECK(collapseBandThickness(0.2, 0.01) == Approx(0.06).epsilon(1e-12));
    CHECK(collapseEnergyRatio(100.0, 0.06, 0.2, 0.05, 100.0, 0.06) ==
          Approx(0.2 / 0.06).epsilon(1e-12));
    CHECK(collapseEnergyRatio(100.0 * 0.2 / 0.06, 0.06, 0.2, 0.05, 100.0, 0.06) ==
          Approx(1.0).epsilon(1e-12));
    // Below the band's length the fine side already keeps the energy: ratio 1 at any dx.
    CHECK(collapseEnergyRatio(100.0, 0.06, 0.2, 0.005, 100.0, 0.06) == Approx(1.0).epsilon(1e-12));
    CHECK(collapseEnergyRatio(100.0, 0.06, 0.06, 0.03, 100.0, 0.06) == Approx(1.0).epsilon(1e-12));

    // alpha 1 (p0 20 kPa, K 667 kPa, xi 5: collapse at eta = asinh(0.03) / 5 = 0.006): a
    // squeeze 0.1 p0 past the tip is a plastic volume change of 0.003, short of collapse.
    MaterialDesc desc = roundDesc(MaterialModel::WeakLayer);
    desc.softening = 1.0;
    desc.softeningLength = 0.06;
    CHECK(Material::fromDesc(desc, 2, 0.005).camClay.alpha == Approx(0.5f));
    CHECK(Material::fromDesc(desc, 2).camClay.alpha == 1.f);
    // Half the alpha: the same plastic volume change softens half as far (eq. 4).
    const Material fine = Material::fromDesc(desc, 2, 0.005);
    const Material point = Material::fromDesc(desc, 2);
    const PlasticState s0 = point.initialState();
    const float p0 = point.camClay.p0Initial;
    const Vec3f squeeze = strainFor(point, 1.1f * p0, 0.f, deviatoricDirection(2));
    const float etaPoint = returnMapWeakLayer(point, squeeze, s0).state.eta;
    const float etaFine = returnMapWeakLayer(fine, squeeze, s0).state.eta;
    REQUIRE(etaPoint > 0.f);
    CHECK(etaFine == Approx(0.5f * etaPoint).epsilon(1e-4));
}
