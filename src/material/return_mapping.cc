// Return mappings in principal Hencky-strain space (snow-model.md; Gaume et al. 2019 sec. 2.2).
//
// With tau = 2 mu eps + lambda tr(eps) 1 over the d principal entries,
//   p = -K tr(eps)                       (K = lambda + 2 mu / d)
//   q = sqrt(3/2) 2 mu |dev(eps)|
// so a target (p, q) maps back to eps = -p / (K d) 1 + dev(eps) q_target / q_trial, and the
// plastic volume change is the change of tr(eps) = log det Fe.
//
// Hardening form (validation.md V6): the paper's eq. (2), p0 = K sinh(xi max(-eps_V^P, 0)), with
// eps_V^P accumulated from the hardening increments of snow-model.md (beyond a tip the plastic
// change of log det Fe; between the tips the ray-to-centre increment); eq. (3) with the
// anticrack strain eta for the weak layer until p0 reaches 0. The update is explicit, as in the
// authors' MPM codes: the trial state is projected onto the surface of the state at the start of
// the step, then the hardening variable is updated. So after a tip projection the state sits on the
// old surface, and where softening outruns elasticity (beta xi > 1 in tension, alpha xi > 1 for the
// weak layer in compression: a snap-back) the surface shrinks over a few steps even at fixed
// strain. That is the brittle failure the model is meant to produce, resolved step by step.
#include <firn/material.h>

#include <algorithm>
#include <cmath>

namespace firn {

namespace {

/// The Cam-Clay surface a projection uses: p0 (Pa), slope M and cohesion ratio beta.
struct CamClaySurface {
    float p0;
    float M;
    float beta;
};

/// Result of a projection in strain space, before any hardening is applied.
struct Projection {
    Vec3f eps;
    /// d eps_V^P, negative in compaction: beyond a tip the real plastic volume change
    /// tr(eps_trial) - tr(eps_new); between the tips the ray-to-centre increment.
    float dVolume = 0.f;
    bool yielded = false;
};

/// 1 on the d principal entries in use, 0 past them. Fixed-size masked arithmetic instead of
/// head(dim): it vectorises without GCC's -Warray-bounds false positives on dynamic blocks.
Vec3f activeMask(int dim) {
    return dim == 2 ? Vec3f(1.f, 1.f, 0.f) : Vec3f::Ones();
}

/// eps = tr/d 1 + dev over the d active entries.
struct StrainSplit {
    float tr;
    Vec3f dev; ///< 0 past dim
    float devNorm;
};

StrainSplit splitStrain(const Vec3f& eps, int dim) {
    const Vec3f mask = activeMask(dim);
    StrainSplit out;
    out.tr = eps.dot(mask);
    out.dev = (eps - (out.tr / float(dim)) * mask).cwiseProduct(mask);
    out.devNorm = out.dev.norm();
    return out;
}

/// eps with its d active entries replaced by those of `active` (entries past dim are kept).
Vec3f replaceActive(const Vec3f& eps, const Vec3f& active, int dim) {
    const Vec3f mask = activeMask(dim);
    return eps.cwiseProduct(Vec3f::Ones() - mask) + active.cwiseProduct(mask);
}

/// The hardening increment of a projection between the tips (snow-model.md, "Hardening
/// increment"; the "fake p" hardening of the authors' code line: PhysBAM's Cam-Clay, Wolper et
/// al. 2019, Ziran's NonAssociativeCamClay). The stress goes to constant p, but the hardening
/// variable moves as if the state had gone along the ray from the trial point (p, q) to the
/// ellipse centre (p_c, 0), p_c = (1 - beta) p0 / 2. That ray meets eq. (1) at
///   p_x = p_c + d_p M (1 + beta) p0 / (2 sqrt((1 + 2 beta) d_q^2 + M^2 d_p^2)),
/// (d_p, d_q) the direction from the centre to the trial point (any length: the root is
/// homogeneous in it), and since p = -K tr(eps), d eps_V^P = (p_x - p) / K. Shear on the tension
/// side of the centre dilates (> 0, softens), on the compression side compacts (< 0, hardens),
/// directly above it changes nothing. Without this, shear yield is perfectly plastic and a weak
/// layer cannot fail in shear (the "mixed mode" of Gaume et al. 2019, sec. 3.1).
float rayToCentreVolumeChange(float K, const CamClaySurface& s, float p, float q) {
    const float pCentre = 0.5f * (1.f - s.beta) * s.p0;
    const float dp = p - pCentre, dq = q;
    const float norm = std::sqrt((1.f + 2.f * s.beta) * dq * dq + s.M * s.M * dp * dp);
    if (!(norm > 0.f)) return 0.f; // the trial sits on the centre: no direction, no change
    const float pOnSurface = pCentre + dp * s.M * (1.f + s.beta) * s.p0 / (2.f * norm);
    return (pOnSurface - p) / K;
}

/// The non-associative Cam-Clay projection of snow-model.md (Wolper et al. 2019, Gaume et al.
/// 2018a): beyond a tip -> that tip; otherwise scale q onto the surface at constant p. Nothing
/// divides by p0, so the degenerate surface p0 = 0 (a point at the origin) stays finite: every
/// trial state then goes to zero stress, and only compaction can harden it again.
Projection projectCamClay(const Lame& lame, int dim, const CamClaySurface& s, const Vec3f& eps) {
    const float K = lame.bulkModulus(dim);
    const StrainSplit split = splitStrain(eps, dim);
    const float tr = split.tr;
    const float p = -K * tr;
    const float q = std::sqrt(1.5f) * 2.f * lame.mu * split.devNorm;

    Projection out;
    out.eps = eps;
    // eq. (1), Gaume et al. 2019; `!(y > 0)` also leaves a NaN state alone for the solver's
    // stability check to find.
    if (!(camClayYield(p, q, s.p0, s.M, s.beta) > 0.f)) return out;
    out.yielded = true;

    const float tensileTip = -s.beta * s.p0;
    if (p > s.p0 || p < tensileTip) {
        // Beyond a tip: the stress goes to the tip, (p0, 0) or (-beta p0, 0). With p0 = 0 (and
        // beta = 0 after weak-layer collapse) both tips are the origin: zero stress.
        const float pTip = p > s.p0 ? s.p0 : tensileTip;
        out.eps = replaceActive(eps, Vec3f::Constant(-pTip / (K * float(dim))), dim);
        out.dVolume = tr + pTip / K; // tr(eps_trial) - tr(eps_tip), since tr(eps_tip) = -pTip/K
        return out;
    }
    // Between the tips: keep p and bring q down to the surface,
    // q_y = M sqrt((p + beta p0)(p0 - p) / (1 + 2 beta)), the root of eq. (1) at this p.
    // max(., 0) absorbs round-off right at a tip; q > 0 here unless round-off put a state with
    // q = 0 an ulp outside, and then the deviator is simply zero.
    const float qYieldSq = std::max((p + s.beta * s.p0) * (s.p0 - p), 0.f) / (1.f + 2.f * s.beta);
    const float scale = q > 0.f ? s.M * std::sqrt(qYieldSq) / q : 0.f;
    out.eps = replaceActive(eps, split.dev * scale + Vec3f::Constant(tr / float(dim)), dim);
    out.dVolume = rayToCentreVolumeChange(K, s, p, q);
    return out;
}

/// Applies a snow-like (eq. 2) hardening step: eps_V^P += dVolume.
PlasticState hardenVolumetric(PlasticState state, const Projection& pr) {
    if (!pr.yielded) return state;
    state.flags |= kFlagFailed;
    state.hardening += pr.dVolume; // eps_V^P, eq. (2): compaction (dVolume < 0) hardens
    state.epsV += pr.dVolume;
    return state;
}

/// Weak layer while cohesive: the anticrack strain eta grows with alpha |d eps_V^P|, eq. (4),
/// and p0 follows eq. (3). Once eta reaches 0 (p0 = 0, time t_c) the layer has collapsed: the
/// hardening variable restarts as eps_V^P = 0 for eq. (2) and the output eta freezes at -eta0.
PlasticState softenAnticrack(PlasticState state, const Projection& pr, float alpha) {
    if (!pr.yielded) return state;
    state.flags |= kFlagFailed;
    state.epsV += pr.dVolume;
    // eq. (4), Gaume et al. 2019: d eta = alpha |d eps_V^P|, with the ray-to-centre increment
    // in shear: the layer softens in shear and in compression (mixed mode)
    const float eta = std::min(state.hardening + alpha * std::abs(pr.dVolume), 0.f);
    state.eta += eta - state.hardening; // eta - eta0, capped at -eta0 when p0 hits 0
    state.hardening = eta;
    if (eta >= 0.f) {
        state.flags |= kFlagCollapsed;
        state.hardening = 0.f; // eps_V^P counted from t_c, eq. (4) for t > t_c
    }
    return state;
}

} // namespace

ReturnMapResult returnMapCamClay(const Material& m, const Vec3f& epsTrial,
                                 const PlasticState& state) {
    const CamClayParams& cc = m.camClay;
    const CamClaySurface surface{m.p0(state), cc.M, cc.beta}; // eq. (2)
    const Projection pr = projectCamClay(m.lame, m.dim, surface, epsTrial);
    return {pr.eps, hardenVolumetric(state, pr)};
}

ReturnMapResult returnMapWeakLayer(const Material& m, const Vec3f& epsTrial,
                                   const PlasticState& state) {
    const CamClayParams& cc = m.camClay;
    if (state.flags & kFlagCollapsed) {
        // After t_c: no cohesion, slope M_d, hardening by eq. (2) on eps_V^P: eq. (5).
        const CamClaySurface surface{m.p0(state), cc.Md, 0.f};
        const Projection pr = projectCamClay(m.lame, m.dim, surface, epsTrial);
        return {pr.eps, hardenVolumetric(state, pr)};
    }
    const CamClaySurface surface{m.p0(state), cc.M, cc.beta}; // eq. (3)
    const Projection pr = projectCamClay(m.lame, m.dim, surface, epsTrial);
    return {pr.eps, softenAnticrack(state, pr, cc.alpha)};
}

ReturnMapResult returnMap(const Material& m, const Vec3f& epsTrial, const PlasticState& state) {
    switch (m.model) {
    case MaterialModel::Snow:
        return returnMapCamClay(m, epsTrial, state);
    case MaterialModel::WeakLayer:
        return returnMapWeakLayer(m, epsTrial, state);
    case MaterialModel::Granular:
        return returnMapMohrCoulomb(m, epsTrial, state);
    case MaterialModel::Elastic:
        break;
    }
    return {epsTrial, state};
}

} // namespace firn
