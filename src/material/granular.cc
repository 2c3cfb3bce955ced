// Cohesionless Mohr-Coulomb granular plasticity in principal Kirchhoff stress.
//
// Yield (tension positive, principal stresses ordered s1 >= s2 >= s3):
//   f = (s1 - s3) + (s1 + s3) sin(phi) <= 0
// (de Souza Neto, Peric & Owen 2008, "Computational Methods for Plasticity", eq. 6.120 with
// c = 0), so the friction angle phi is the one a Mohr circle touches, in any dimension. The
// return is non-associative with dilatancy angle psi = 0: the plastic potential is
// g = s1 - s3 (Tresca), so plastic flow is traceless (no plastic volume change, as the
// Drucker-Prager model it replaces and a granular material at critical state) and never touches
// the intermediate principal direction. Returns on a plane, on an edge and the apex follow
// de Souza Neto et al. 2008, Box 8.1, with psi = 0.
//
// Hencky elasticity is tau = 2 mu eps + lambda tr(eps) 1, so a traceless plastic strain
// increment d changes the stress by -2 mu d at fixed tr(eps): the whole return is done on the
// stresses at fixed pressure and mapped back with eps += (tau_new - tau_trial) / (2 mu).
//
// 2D is plane strain: the out-of-plane elastic strain is 0 and the out-of-plane stress is
// tau_3 = lambda tr(eps) (the 2D `kirchhoffPrincipal` leaves that entry 0 because the solver has
// no use for it; a 0 there must not be read as a principal stress: cohesionless Mohr-Coulomb
// with one zero principal stress admits only zero stress). A 3D point held in plane strain with
// psi = 0 flows out of plane only while tau_3 is the major or minor principal stress: that flow
// moves tau_3 into the in-plane range, where it stays (the potential does not touch the
// intermediate direction), so every flowing state has the in-plane pair on the surface and
// mobilises exactly phi in-plane. When sin(phi) >= 1 - 2 nu (nu = 0.3: phi >= 23.6 deg) tau_3
// is intermediate at every in-plane yield state and that out-of-plane transient never happens:
// 2D and the 3D point are then the same, step by step. 2D carries no out-of-plane elastic
// strain to follow the transient below that bound, so it takes its end state: the in-plane
// circle on the surface, tau_3 not limiting.
#include <firn/material.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace firn {

namespace {

constexpr float kPi = 3.14159265358979323846f;

float sinFriction(const Material& m) {
    return std::sin(m.frictionAngleDeg * kPi / 180.f);
}

/// The apex: a cohesionless material carries no tension, so any state with tr(eps) >= 0 goes to
/// zero stress, and its whole volume change is plastic.
ReturnMapResult toApex(const Material& m, const Vec3f& epsTrial, const PlasticState& state,
                       float tr) {
    ReturnMapResult out{epsTrial, state};
    for (int i = 0; i < m.dim; ++i) out.eps[i] = 0.f;
    out.state.epsV += tr;
    out.state.flags |= kFlagFailed;
    return out;
}

/// Plane strain: the in-plane Mohr circle has centre c = (lambda + mu) tr(eps) and radius
/// r = mu |eps1 - eps2|; f = 2 r + 2 c sin(phi) <= 0. The return scales the in-plane deviator at
/// fixed tr(eps), the psi = 0 flow (1, -1) / sqrt(2).
ReturnMapResult returnPlaneStrain(const Material& m, const Vec3f& epsTrial,
                                  const PlasticState& state, float tr) {
    ReturnMapResult out{epsTrial, state};
    const float centre = (m.lame.lambda + m.lame.mu) * tr; // < 0 (compression)
    const float halfDiff = 0.5f * (epsTrial[0] - epsTrial[1]);
    const float radius = 2.f * m.lame.mu * std::abs(halfDiff);
    const float radiusYield = -centre * sinFriction(m);
    if (!(radius > radiusYield)) return out;  // inside (a NaN stays for the stability check)
    const float scale = radiusYield / radius; // radius > radiusYield >= 0
    out.eps[0] = 0.5f * tr + halfDiff * scale;
    out.eps[1] = 0.5f * tr - halfDiff * scale;
    out.state.flags |= kFlagFailed;
    return out;
}

/// 3D: the return in ordered principal stresses s[0] >= s[1] >= s[2] (tension positive) at fixed
/// pressure p > 0, de Souza Neto et al. 2008 Box 8.1 with psi = 0. Returns the new stresses.
std::array<float, 3> returnPrincipal3(const std::array<float, 3>& s, float twoMu, float sinPhi) {
    const float onePlus = 1.f + sinPhi, oneMinus = 1.f - sinPhi;
    const auto yield = [&](float major, float minor) {
        return (major - minor) + (major + minor) * sinPhi;
    };
    // Main plane (s1, s3), flow (1, 0, -1): f drops by 2 twoMu dGamma.
    const float fMain = yield(s[0], s[2]);
    const float dGamma = fMain / (2.f * twoMu);
    std::array<float, 3> out{s[0] - twoMu * dGamma, s[1], s[2] + twoMu * dGamma};
    if (out[0] >= out[1] && out[1] >= out[2]) return out;
    if (out[0] < out[1]) {
        // Edge s1 = s2: planes a (s1, s3) and b (s2, s3), flows (1, 0, -1) and (0, 1, -1):
        // [2, 1 - sin; 1 - sin, 2] twoMu [ga; gb] = [fa; fb].
        const float fB = yield(s[1], s[2]);
        const float det = 4.f - oneMinus * oneMinus;
        const float ga = (2.f * fMain - oneMinus * fB) / (det * twoMu);
        const float gb = (2.f * fB - oneMinus * fMain) / (det * twoMu);
        return {s[0] - twoMu * ga, s[1] - twoMu * gb, s[2] + twoMu * (ga + gb)};
    }
    // Edge s2 = s3: planes a (s1, s3) and c (s1, s2), flows (1, 0, -1) and (1, -1, 0):
    // [2, 1 + sin; 1 + sin, 2] twoMu [ga; gc] = [fa; fc].
    const float fC = yield(s[0], s[1]);
    const float det = 4.f - onePlus * onePlus;
    const float ga = (2.f * fMain - onePlus * fC) / (det * twoMu);
    const float gc = (2.f * fC - onePlus * fMain) / (det * twoMu);
    return {s[0] - twoMu * (ga + gc), s[1] + twoMu * gc, s[2] + twoMu * ga};
}

ReturnMapResult returnSpace(const Material& m, const Vec3f& epsTrial, const PlasticState& state) {
    ReturnMapResult out{epsTrial, state};
    const Vec3f tau = kirchhoffPrincipal(m.lame, epsTrial, 3);
    std::array<int, 3> order{0, 1, 2}; // indices of tau, descending (most tensile first)
    std::sort(order.begin(), order.end(), [&](int a, int b) { return tau[a] > tau[b]; });
    const std::array<float, 3> s{tau[order[0]], tau[order[1]], tau[order[2]]};
    const float sinPhi = sinFriction(m);
    if (!((s[0] - s[2]) + (s[0] + s[2]) * sinPhi > 0.f)) return out; // inside; NaN stays
    const float twoMu = 2.f * m.lame.mu;
    const std::array<float, 3> sNew = returnPrincipal3(s, twoMu, sinPhi);
    for (int k = 0; k < 3; ++k) out.eps[order[k]] += (sNew[k] - s[k]) / twoMu;
    out.state.flags |= kFlagFailed;
    return out;
}

} // namespace

float inertialNumber(const Material& m, float shearRate, float pressure) {
    if (!(pressure > 0.f)) return std::numeric_limits<float>::infinity();
    return shearRate * m.grainDiameter / std::sqrt(pressure / m.density);
}

float frictionAngleAt(const Material& m, float inertialNumber) {
    if (!m.rateDependent() || !(inertialNumber > 0.f)) return m.frictionAngleDeg;
    const float sinStatic = sinFriction(m);
    const float sinDynamic = std::sin(m.dynamicFrictionAngleDeg * kPi / 180.f);
    const float sinPhi =
        sinStatic + (sinDynamic - sinStatic) / (1.f + m.inertialNumberScale / inertialNumber);
    return std::asin(sinPhi) * 180.f / kPi;
}

float mohrCoulombYieldBound(const Material& m, float trEps, float devNorm) {
    // Half of f over the extreme pair: the Mohr circle radius mu (e_max - e_min) plus its centre
    // K tr + mu (e_max + e_min) times sin(phi), with e the deviatoric strain, |e| = devNorm.
    const Lame& lame = m.lame;
    const float sinPhi = sinFriction(m);
    if (m.dim == 2) {
        // Exact: e = devNorm (1, -1) / sqrt(2), plane-strain centre (lambda + mu) tr.
        return std::sqrt(2.f) * lame.mu * devNorm + (lame.lambda + lame.mu) * trEps * sinPhi;
    }
    // Over the Lode angle e_max - e_min <= sqrt(2) |e| (shear meridian) and
    // e_max + e_min = -e_mid <= |e| / sqrt(6) (compression meridian): an upper bound.
    return lame.mu * (std::sqrt(2.f) + sinPhi / std::sqrt(6.f)) * devNorm +
           lame.bulkModulus(3) * trEps * sinPhi;
}

ReturnMapResult returnMapMohrCoulomb(const Material& m, const Vec3f& epsTrial,
                                     const PlasticState& state) {
    float tr = 0.f;
    for (int i = 0; i < m.dim; ++i) tr += epsTrial[i];
    if (tr >= 0.f) {
        bool stressFree = true;
        for (int i = 0; i < m.dim; ++i) stressFree = stressFree && epsTrial[i] == 0.f;
        if (stressFree) return {epsTrial, state};
        return toApex(m, epsTrial, state, tr);
    }
    return m.dim == 2 ? returnPlaneStrain(m, epsTrial, state, tr) : returnSpace(m, epsTrial, state);
}

} // namespace firn
