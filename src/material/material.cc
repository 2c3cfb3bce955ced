// Material parameters, Hencky elasticity and the Cam-Clay invariants (Gaume et al. 2019,
// sec. 2.2; snow-model.md). The return mappings live in return_mapping.cc.
#include <firn/material.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace firn {

namespace {

/// Largest argument passed to sinh in eq. (2): sinh(60) ~ 5.7e25, so K sinh() stays finite in
/// float for any K below ~1e12 Pa, while p0 at that point is already absurdly large.
constexpr float kMaxSinhArg = 60.f;

/// Sum of the d principal entries in use (plain loops: d is 2 or 3, and Eigen's dynamic head()
/// trips GCC's -Warray-bounds when vectorised).
float trace(const Vec3f& v, int dim) {
    float tr = 0.f;
    for (int i = 0; i < dim; ++i) tr += v[i];
    return tr;
}

} // namespace

Lame Lame::fromYoungPoisson(double youngsModulus, double poissonRatio) {
    const double E = youngsModulus, nu = poissonRatio;
    Lame lame;
    lame.mu = float(E / (2.0 * (1.0 + nu)));
    lame.lambda = float(E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)));
    return lame;
}

double crackBandSoftening(double softening, double softeningLength, double dx) {
    if (softeningLength <= 0.0 || dx <= 0.0) return softening;
    return softening * std::min(1.0, kCrackBandCells * dx / softeningLength);
}

double collapseBandThickness(double layerThickness, double dx) {
    return std::min(kCrackBandCells * dx, layerThickness);
}

double collapseEnergyRatio(double softening, double softeningLength, double layerThickness,
                           double dx, double tableSoftening, double tableSofteningLength) {
    const double alpha = crackBandSoftening(softening, softeningLength, dx);
    return collapseBandThickness(layerThickness, dx) / alpha * tableSoftening /
           tableSofteningLength;
}

Material Material::fromDesc(const MaterialDesc& desc, int dim, double dx) {
    Material m;
    m.model = desc.model;
    m.density = float(desc.density);
    m.lame = Lame::fromYoungPoisson(desc.youngsModulus, desc.poissonRatio);
    m.camClay.M = float(desc.criticalStateSlope);
    m.camClay.beta = float(desc.cohesionRatio);
    m.camClay.xi = float(desc.hardening);
    m.camClay.alpha = float(crackBandSoftening(desc.softening, desc.softeningLength, dx));
    m.camClay.Md = float(desc.dynamicCriticalStateSlope);
    m.camClay.p0Initial = float(desc.initialP0);
    m.frictionAngleDeg = float(desc.frictionAngle);
    // Below the angle at rest (a MaterialDesc built in code, left at its defaults) mu(I) is off;
    // the scene reader rejects it.
    m.dynamicFrictionAngleDeg = float(std::max(desc.dynamicFrictionAngle, desc.frictionAngle));
    m.grainDiameter = float(desc.grainDiameter);
    m.inertialNumberScale = float(desc.inertialNumberScale);
    m.dim = dim;
    const float h = m.initialState().hardening;
    const float K = m.lame.bulkModulus(dim);
    m.initialP0 = {K, m.camClay.xi, h, camClayP0(K, m.camClay.xi, h)};
    return m;
}

PlasticState Material::initialState() const {
    PlasticState state;
    if (model != MaterialModel::Snow && model != MaterialModel::WeakLayer) return state;
    // Invert eq. (2) (eq. (3) for the weak layer, where this is eta0), Gaume et al. 2019:
    // p0Initial = K sinh(xi * (-h))  =>  h = -asinh(p0Initial / K) / xi.
    // In double: p0Initial / K is ~1e-3 and the result is stored as a float offset.
    const double K = lame.bulkModulus(dim);
    if (camClay.xi > 0.f && K > 0.0)
        state.hardening = float(-std::asinh(double(camClay.p0Initial) / K) / camClay.xi);
    // xi = 0 (or K = 0) cannot reach any p0 > 0 through eq. (2); the state starts at p0 = 0.
    return state;
}

float Material::pWaveSpeed() const {
    return std::sqrt((lame.lambda + 2.f * lame.mu) / density);
}

Vec3f kirchhoffPrincipal(const Lame& lame, const Vec3f& eps, int dim) {
    const float tr = trace(eps, dim);
    Vec3f tau = Vec3f::Zero();
    for (int i = 0; i < dim; ++i) tau[i] = 2.f * lame.mu * eps[i] + lame.lambda * tr;
    return tau;
}

float henckyEnergy(const Lame& lame, const Vec3f& eps, int dim) {
    const float tr = trace(eps, dim);
    float epsSq = 0.f;
    for (int i = 0; i < dim; ++i) epsSq += eps[i] * eps[i];
    return lame.mu * epsSq + 0.5f * lame.lambda * tr * tr;
}

StressInvariants stressInvariants(const Vec3f& tauPrincipal, int dim) {
    // Gaume et al. 2019, sec. 2.2: p = -tr(tau)/d, s = tau + p I, q = sqrt(3/2 s:s).
    StressInvariants inv;
    inv.p = -trace(tauPrincipal, dim) / float(dim);
    float ss = 0.f;
    for (int i = 0; i < dim; ++i) ss += (tauPrincipal[i] + inv.p) * (tauPrincipal[i] + inv.p);
    inv.q = std::sqrt(1.5f * ss);
    return inv;
}

float camClayYield(float p, float q, float p0, float M, float beta) {
    // eq. (1), Gaume et al. 2019
    return (1.f + 2.f * beta) * q * q + M * M * (p + beta * p0) * (p - p0);
}

double camClayStrengthUsed(double p, double q, double p0, double M, double beta) {
    // y(lambda p, lambda q) = a lambda^2 + b lambda + c with c = -M^2 beta p0^2 <= 0: one root
    // lambda > 0 (the ray leaves the surface once), and 1 / lambda = 2 a / (-b + sqrt(b^2 - 4ac)).
    const double a = (1.0 + 2.0 * beta) * q * q + M * M * p * p;
    if (a == 0.0) return 0.0; // zero stress uses none of it
    const double b = M * M * p * p0 * (beta - 1.0);
    const double c = -M * M * beta * p0 * p0;
    const double denominator = -b + std::sqrt(std::max(b * b - 4.0 * a * c, 0.0));
    if (!(p0 > 0.0) || !(denominator > 0.0)) return std::numeric_limits<double>::infinity();
    return 2.0 * a / denominator;
}

float camClayP0(float K, float xi, float hardeningVariable) {
    // eq. (2) (and eq. (3) with the anticrack strain), Gaume et al. 2019
    const float arg = std::min(xi * std::max(0.f, -hardeningVariable), kMaxSinhArg);
    return K * std::sinh(arg);
}

bool slabFractured(const Material& m, const PlasticState& state) {
    if (m.model != MaterialModel::Snow || !(m.camClay.p0Initial > 0.f)) return false;
    const float p0 = m.p0(state);
    return p0 <= kSlabFractureP0Ratio * m.camClay.p0Initial;
}

} // namespace firn
