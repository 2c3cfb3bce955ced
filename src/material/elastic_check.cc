// The yield test without a principal decomposition: every model's yield function depends on
// the elastic strain only through tr(eps) and |dev(eps)| (Hencky elasticity is isotropic).
#include <firn/material.h>

#include <cmath>

namespace firn {

namespace {
constexpr float kPi = 3.14159265358979323846f;
}

bool staysElastic(const Material& m, float trEps, float devNorm, const PlasticState& state) {
    const Lame& lame = m.lame;
    switch (m.model) {
    case MaterialModel::Elastic:
        return true;
    case MaterialModel::Granular: {
        // Klar et al. 2016, sec. 7.3: inside the cone when delta_gamma <= 0 under compression.
        if (trEps >= 0.f) return trEps == 0.f && devNorm == 0.f;
        const float sinPhi = std::sin(m.frictionAngleDeg * kPi / 180.f);
        const float alpha = std::sqrt(2.f / 3.f) * 2.f * sinPhi / (3.f - sinPhi);
        const float dGamma = devNorm + (float(m.dim) * lame.lambda + 2.f * lame.mu) /
                                           (2.f * lame.mu) * trEps * alpha;
        return dGamma <= 0.f;
    }
    case MaterialModel::Snow:
    case MaterialModel::WeakLayer: {
        const CamClayParams& cc = m.camClay;
        const float K = lame.bulkModulus(m.dim);
        const bool collapsed =
            m.model == MaterialModel::WeakLayer && (state.flags & kFlagCollapsed);
        const float p0 = camClayP0(K, cc.xi, state.hardening); // eqs. (2), (3)
        const float p = -K * trEps;
        const float q = std::sqrt(1.5f) * 2.f * lame.mu * devNorm;
        // eq. (1); eq. (5) after weak-layer collapse (beta = 0, M = M_d)
        return camClayYield(p, q, p0, collapsed ? cc.Md : cc.M, collapsed ? 0.f : cc.beta) <= 0.f;
    }
    }
    return false;
}

} // namespace firn
