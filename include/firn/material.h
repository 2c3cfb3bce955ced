// Constitutive models as small value types with pure functions, tested at a single point.
// Everything works in principal space: `eps` holds the d principal Hencky (logarithmic) strains
// of the elastic deformation gradient (d = dimension; in 2D the third entry is ignored and 0).
// A return mapping returns the projected strains and the new plastic state; it changes nothing
// else (style.md: no hidden state mutated in another object).
#pragma once

#include <firn/scene.h>

#include <Eigen/Core>
#include <cstdint>
#include <limits>

namespace firn {

using Vec3f = Eigen::Vector3f;

/// Lamé parameters from Young's modulus and Poisson's ratio.
struct Lame {
    float mu = 0.f;
    float lambda = 0.f;
    static Lame fromYoungPoisson(double youngsModulus, double poissonRatio);
    /// Bulk modulus in d dimensions, K = lambda + 2 mu / d (snow-model.md).
    float bulkModulus(int dim) const { return lambda + 2.f * mu / float(dim); }
};

/// Per-particle plastic state. Stored as plain fields in the particle store.
struct PlasticState {
    /// Hardening variable. Snow: eps_V^P (total plastic volume strain incl. the initial offset
    /// that gives p0 = initial_p0). Weak layer: eta while cohesive, then eps_V^P counted from
    /// the moment of full softening. Granular and elastic: unused.
    float hardening = 0.f;
    /// eps_V^P accumulated since t = 0 from the hardening increments of snow-model.md (output
    /// `eps_v`; between the tips this is the ray-to-centre increment, not a volume change)
    float epsV = 0.f;
    float eta = 0.f; ///< anticrack strain since t = 0, eta - eta0 (output `eta`)
    std::uint32_t flags = 0;
    /// Snow slab: simulated time (s) of the step in which slabFractured() first held, set with
    /// kFlagSlabFractured; weak layer: of the step in which eta first exceeded 0, set with
    /// kFlagCracked (the crack's arrival, timed to the step). 0 until then.
    float fractureTime = 0.f;
};
constexpr std::uint32_t kFlagFailed = 1u;    ///< yield reached at least once
constexpr std::uint32_t kFlagCollapsed = 2u; ///< weak layer fully softened (p0 reached 0)
/// Asleep (solver sleeping): v = 0 and the C slot holds the frozen Kirchhoff stress, since an
/// asleep particle has no velocity gradient and its stress array is scratch for re-bucketing.
constexpr std::uint32_t kFlagAsleep = 4u;
/// Seeding marks, cleared before t = 0: inside a saw cut (removed once the scene has settled,
/// as a saw cuts a snowpack at rest), and of a body that does not rest (seeded with a velocity,
/// or in the air: kept out of the settling stage and put back as seeded at t = 0).
constexpr std::uint32_t kFlagInCut = 8u;
constexpr std::uint32_t kFlagOutsideSettling = 16u;
/// Snow slab particle softened to slabFractured() at least once (fractureTime says when).
constexpr std::uint32_t kFlagSlabFractured = 32u;
/// Faster than kMovedSpeed at least once since t = 0: part of the avalanche (released or
/// entrained), what runout_x and alpha_angle_deg measure (not snow that never moved).
constexpr std::uint32_t kFlagMoved = 64u;
/// Left the simulated domain: removed at the end of the frame (removeOutflow).
constexpr std::uint32_t kFlagOutside = 128u;
/// Weak-layer particle whose eta exceeded 0 (part of the anticrack; fractureTime says when).
constexpr std::uint32_t kFlagCracked = 256u;
/// Of a body above the slip surface (BodyDesc::slidesOn): scatters to and reads from the upper
/// velocity field (firn/slip_contact.h).
constexpr std::uint32_t kFlagUpperField = 512u;
constexpr float kMovedSpeed = 0.1f; ///< m/s, outputs.md's threshold for moving snow (front_x)

/// Cohesive Cam-Clay parameters (Gaume et al. 2019 eqs. 1-5).
struct CamClayParams {
    float M = 1.f;            ///< critical state slope
    float beta = 0.3f;        ///< cohesion ratio: tensile strength beta * p0
    float xi = 5.f;           ///< hardening factor in p0 = K sinh(xi max(-eps, 0))
    float alpha = 1.f;        ///< weak layer softening factor
    float Md = 1.2f;          ///< weak layer slope after full softening (eq. 5)
    float p0Initial = 2.0e4f; ///< Pa
};

/// How many cells thick the band is that a weak layer's collapse leaves behind the crack tip
/// (quadratic B-splines), measured on the PST layer (docs/snow.md, Resolution): 5.6 cells
/// (p10-p90: 4-7) at dx 0.0075, where it is 70 % of the 6 cm layer, and the whole layer at
/// dx 0.015. The 2-3 cells that soften at the tip itself over-correct: with 3, the flat crack
/// arrests before the column's end (a_c > 0.65 m at dx 0.0075 against 0.45-0.475 m at 0.015).
constexpr double kCrackBandCells = 6.0;

/// Crack-band regularisation of the weak layer's softening factor alpha (Bazant & Oh 1983): the
/// energy a collapse dissipates per unit area is (band thickness) x (energy per volume, which
/// scales with 1/alpha), so where the band, kCrackBandCells * dx, is thinner than the layer
/// thickness `softeningLength` that alpha was measured for, alpha shrinks in proportion.
/// softeningLength 0, dx 0 or a band at least that thick: alpha unchanged.
double crackBandSoftening(double softening, double softeningLength, double dx);

/// Thickness of the band a weak layer's collapse fills on a grid of spacing dx, m: kCrackBandCells
/// cells, or the whole layer where the layer is thinner (a 0.2 m layer at dx 0.05: all of it).
double collapseBandThickness(double layerThickness, double dx);

/// Energy a weak layer's collapse dissipates per unit area on a grid of spacing dx, relative to
/// the layer the table's alpha was calibrated on (`tableSoftening` on a `tableSofteningLength`
/// layer that the collapse filled). The energy per volume scales with 1/alpha (eq. 4), so the
/// ratio is (band / alpha at this dx) / (tableSofteningLength / tableSoftening), and `softening`
/// x ratio gives the table's energy per area. The crack band's coarse side: a layer thicker than
/// the calibrated one, on a grid that lets the collapse fill it, dissipates more per unit area
/// (slope2d's 0.2 m layer with alpha 100: 3.3 times; docs/slope-scale.md).
double collapseEnergyRatio(double softening, double softeningLength, double layerThickness,
                           double dx, double tableSoftening, double tableSofteningLength);

/// Hardening law p0 = K sinh(xi max(-e, 0)), eq. (2) (and eq. (3) with e = eta).
float camClayP0(float K, float xi, float hardeningVariable);

/// A material as the solver uses it: model, density, elasticity and plasticity parameters.
struct Material {
    MaterialModel model = MaterialModel::Elastic;
    float density = 0.f; ///< kg/m^3
    Lame lame;
    CamClayParams camClay;
    float frictionAngleDeg = 30.f; ///< granular (Mohr-Coulomb friction angle; at rest with mu(I))
    /// Granular mu(I): the Mohr-Coulomb angle at large inertial number; equal to
    /// frictionAngleDeg when the friction does not depend on the shear rate.
    float dynamicFrictionAngleDeg = 30.f;
    float grainDiameter = 1.0e-3f;      ///< m, d of the inertial number
    float inertialNumberScale = 0.279f; ///< I_0 of mu(I)
    int dim = 3;
    /// A slab for the slab-fracture detector: a `snow` material of a layer that lies on a weak
    /// layer, or every `snow` material of a scene without a weak layer (set by buildWorld). A
    /// base of old snow under the weak layer is not slab.
    bool slab = false;
    /// p0 at the initial state, with what it was computed from (set by fromDesc; a key that no
    /// longer matches, as after a change of the parameters, falls back to camClayP0).
    struct P0Memo {
        float K = std::numeric_limits<float>::quiet_NaN();
        float xi = std::numeric_limits<float>::quiet_NaN();
        float hardening = std::numeric_limits<float>::quiet_NaN();
        float p0 = 0.f;
    } initialP0;

    /// The material on a grid of spacing dx (m), where a weak layer's softening is regularised
    /// (crackBandSoftening); dx 0: a single material point, the softening as given.
    static Material fromDesc(const MaterialDesc& desc, int dim, double dx = 0.0);
    /// The plastic state a fresh particle of this material starts in (p0 = initial_p0).
    PlasticState initialState() const;
    /// P-wave speed sqrt((lambda + 2 mu) / rho), for the CFL time step.
    float pWaveSpeed() const;
    /// Cam-Clay's p0 at `state`, eq. (2) (eq. (3) for a weak layer): bitwise
    /// camClayP0(K, xi, state.hardening). Most snow never yields, and the elastic check asks
    /// for it every step (sinhf was 2.7 % of slope2d), so the initial state's value is kept.
    float p0(const PlasticState& state) const {
        const float K = lame.bulkModulus(dim);
        const P0Memo& memo = initialP0;
        if (K == memo.K && camClay.xi == memo.xi && state.hardening == memo.hardening)
            return memo.p0;
        return camClayP0(K, camClay.xi, state.hardening);
    }
    /// Granular with a friction that rises with the inertial number (mu(I)).
    bool rateDependent() const {
        return model == MaterialModel::Granular && dynamicFrictionAngleDeg > frictionAngleDeg;
    }
};

/// Principal Kirchhoff stresses tau_i = 2 mu eps_i + lambda tr(eps) (Hencky / St. Venant-Kirchhoff
/// in logarithmic strain). Entries past dim are 0.
Vec3f kirchhoffPrincipal(const Lame& lame, const Vec3f& eps, int dim);

/// Hencky strain energy density per reference volume, mu |eps|^2 + lambda/2 tr(eps)^2.
float henckyEnergy(const Lame& lame, const Vec3f& eps, int dim);

/// The paper's invariants from principal Kirchhoff stresses: p = -tr(tau)/d, q = sqrt(3/2 s:s).
struct StressInvariants {
    float p = 0.f;
    float q = 0.f;
};
StressInvariants stressInvariants(const Vec3f& tauPrincipal, int dim);

/// Cam-Clay yield function y(p, q) = (1 + 2 beta) q^2 + M^2 (p + beta p0)(p - p0), eq. (1).
float camClayYield(float p, float q, float p0, float M, float beta);

/// Share of a Cam-Clay surface's strength that the stress (p, q) uses under proportional
/// loading: 1 / lambda, where lambda > 0 scales (p, q) onto the surface, y(lambda p, lambda q) = 0
/// (eq. 1). 0 at zero stress, 1 on the surface, > 1 beyond it; +infinity where no scale reaches
/// the surface (p0 <= 0 with a stress, or tension without cohesion, beta = 0).
double camClayStrengthUsed(double p, double q, double p0, double M, double beta);

/// Share of the initial cohesion below which a snow slab particle counts as fractured.
constexpr float kSlabFractureP0Ratio = 0.5f;

/// Slab fracture criterion: a `snow` particle whose cohesion p0 (eq. (2)) has softened through
/// plastic dilation to at most kSlabFractureP0Ratio of its initial value. Tensile slab fractures
/// appear that way (Gaume et al. 2019, sec. 3; snow-model.md). False for every other model.
bool slabFractured(const Material& m, const PlasticState& state);

struct ReturnMapResult {
    Vec3f eps;          ///< projected principal strains
    PlasticState state; ///< updated plastic state
};

/// Snow slab: non-associative cohesive Cam-Clay return mapping with hardening eq. (2).
ReturnMapResult returnMapCamClay(const Material& m, const Vec3f& epsTrial,
                                 const PlasticState& state);
/// Weak layer: softening with the anticrack strain (eqs. 3-4), then frictional with M_d (eq. 5).
ReturnMapResult returnMapWeakLayer(const Material& m, const Vec3f& epsTrial,
                                   const PlasticState& state);
/// Cohesionless Mohr-Coulomb with zero dilatancy in principal Kirchhoff stress (granular.cc):
/// tension -> apex, else return at fixed pressure onto f = s1 - s3 + (s1 + s3) sin(phi) = 0
/// (de Souza Neto et al. 2008, Box 8.1). 2D is plane strain (see granular.cc).
ReturnMapResult returnMapMohrCoulomb(const Material& m, const Vec3f& epsTrial,
                                     const PlasticState& state);
/// Inertial number I = shearRate d / sqrt(p / rho) (GDR MiDi 2004), with the material's grain
/// diameter d and density rho; `shearRate` = sqrt(2 D':D') (1/s, simple shear: its rate),
/// `pressure` in Pa. Infinite at p <= 0 (the free surface: the apex takes that state anyway).
float inertialNumber(const Material& m, float shearRate, float pressure);

/// The mu(I) friction as a Mohr-Coulomb angle in degrees: sin(phi) runs from sin(phi_s) at rest
/// to sin(phi_2) as I passes I_0, sin(phi) = sin(phi_s) + (sin(phi_2) - sin(phi_s)) / (1 + I_0 / I)
/// (Jop, Forterre & Pouliquen 2006, eq. 2, with mu = sin(phi): the simple-shear friction of a
/// non-dilatant Mohr-Coulomb material). frictionAngleDeg when the material is rate-independent.
float frictionAngleAt(const Material& m, float inertialNumber);

/// An upper bound on f / 2 of the granular model at compressive strain trace `trEps` and
/// deviatoric norm `devNorm` over all Lode angles (exact in 2D): <= 0 means inside.
float mohrCoulombYieldBound(const Material& m, float trEps, float devNorm);

/// True when a strain with trace `trEps` and deviatoric norm `devNorm` (over the d x d block)
/// lies strictly inside the current yield surface of the particle, so that the return mapping
/// would change nothing. Lets the solver skip the principal decomposition for most particles.
bool staysElastic(const Material& m, float trEps, float devNorm, const PlasticState& state);

/// Dispatch on m.model; Elastic returns the input unchanged.
ReturnMapResult returnMap(const Material& m, const Vec3f& epsTrial, const PlasticState& state);

} // namespace firn
