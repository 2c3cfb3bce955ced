// The snow parameter table (docs/snow.md, parameter table). Two published laws of snow against
// density carry the density dependence, the rest is the calibrated PST set of scenes/pst.toml:
//
// - Young's modulus of slabs, van Herwijnen et al. 2016 (J. Glaciol. 62(236):997-1007): a power
//   law fitted to effective slab moduli from particle tracking in 80 field PSTs,
//   E = 0.93 rho^2.8 Pa. Their moduli span 0.08-34 MPa, which the law reaches at 58-500 kg/m^3:
//   that span is the slab table's validity range (the paper's own density span could not be read
//   from this workplace). E(250) = 4.82 MPa, close to the calibrated 5 MPa.
// - Tensile strength, Sigrist 2006 (PhD thesis, ETH Zurich; as eq. 22 of Weissgraeber and
//   Rosendahl 2023, The Cryosphere 17:1475): sigma_t = 240 kPa (rho / 917)^2.44.
//
// The Cam-Clay parameter that holds the strength is p0; it follows from sigma_t through the
// ellipse (uniaxialTensileStrength), with the material's beta and M. No published compressive-
// strength or friction law was found, nor the parameter tables of Gaume et al. 2018a (Nat.
// Commun. 9:3047, Methods) or of Reiweger et al. 2015's mixed-mode envelope: beta, M, xi (and
// for the weak layer alpha, M_d) are the Firn PST calibration, constant in density.
//
// The weak layer is the calibrated PST layer at 100 kg/m^3 (E 0.48 MPa, p0 6.9 kPa, whose
// uniaxial tensile strength is 1.156 kPa). The laws above agree with it there within their
// scatter (E 0.37 MPa, sigma_t 1.08 kPa) but were fitted to slabs, so the weak layer keeps its
// calibrated values at 100 kg/m^3 and takes only the laws' density exponents away from it, in a
// range of a factor 5/3 below and 2 above (60-200 kg/m^3).
#include <firn/snow_parameters.h>

#include <cmath>

namespace firn {
namespace {

constexpr double kIceDensity = 917.0; // kg/m^3, Sigrist 2006's reference density

// van Herwijnen et al. 2016: E = 0.93 rho^2.8 Pa.
constexpr double kSlabModulusCoefficient = 0.93; // Pa
constexpr double kSlabModulusExponent = 2.8;
// Sigrist 2006: sigma_t = 240 kPa (rho / rho_ice)^2.44.
constexpr double kIceTensileStrength = 240.0e3; // Pa
constexpr double kTensileExponent = 2.44;

// The Firn PST calibration (docs/snow.md; scenes/pst.toml).
constexpr double kSlabPoissonRatio = 0.2;
constexpr double kSlabCriticalStateSlope = 1.0;
constexpr double kSlabCohesionRatio = 0.5;
constexpr double kSlabHardening = 0.5;
constexpr double kWeakYoungsModulus = 4.8e5; // Pa, shear modulus 0.2 MPa (validation.md V8)
constexpr double kWeakPoissonRatio = 0.2;
constexpr double kWeakCriticalStateSlope = 0.85;
constexpr double kWeakCohesionRatio = 0.1;
constexpr double kWeakInitialP0 = 6900.0; // Pa
constexpr double kWeakHardening = 0.015;
constexpr double kWeakSoftening = 100.0;
constexpr double kWeakSofteningLength = 0.06; // m, the PST's weak layer
constexpr double kWeakDynamicCriticalStateSlope = 1.2;

const DensityRange kSlabDensities{60.0, 500.0};
const DensityRange kWeakLayerDensities{60.0, 200.0};

const char* const kCalibration = "Firn PST calibration, docs/snow.md";

TableValue calibrated(double value) {
    return {value, kCalibration};
}

} // namespace

double slabYoungsModulus(double density) {
    return kSlabModulusCoefficient * std::pow(density, kSlabModulusExponent);
}

double tensileStrength(double density) {
    return kIceTensileStrength * std::pow(density / kIceDensity, kTensileExponent);
}

// Uniaxial tension sigma > 0 (tension negative in p, as p = -tr(tau)/3 is compression
// positive): tau = diag(sigma, 0, 0), so p = -sigma/3, s = diag(2, -1, -1) sigma/3 and
// q = sqrt(3/2 s:s) = sigma. On the surface of eq. (1), y = 0:
//   (1 + 2 beta) sigma^2 + M^2 (beta p0 - sigma/3)(-sigma/3 - p0) = 0
//   <=> a sigma^2 + b p0 sigma - c p0^2 = 0,
//   a = 1 + 2 beta + M^2/9,  b = M^2 (1 - beta)/3,  c = M^2 beta,
// whose positive root is sigma = p0 (-b + sqrt(b^2 + 4 a c)) / (2 a). As M -> infinity the root
// tends to 3 beta p0 (p at the tensile tip); for beta 0.5, M 1 it is 0.4488 p0.
double uniaxialTensileStrength(double p0, double beta, double M) {
    const double m2 = M * M;
    const double a = 1.0 + 2.0 * beta + m2 / 9.0;
    const double b = m2 * (1.0 - beta) / 3.0;
    const double c = m2 * beta;
    return p0 * (-b + std::sqrt(b * b + 4.0 * a * c)) / (2.0 * a);
}

double p0FromUniaxialTensileStrength(double sigmaT, double beta, double M) {
    return sigmaT / uniaxialTensileStrength(1.0, beta, M);
}

TableValue initialP0FromTable(const SnowParameterTable& table, double beta, double M) {
    return {p0FromUniaxialTensileStrength(table.tensileStrength.value, beta, M),
            "p0 on the ellipse (beta, M) from " + table.tensileStrength.source};
}

SnowParameterTable slabTable(double density) {
    SnowParameterTable t;
    t.density = density;
    t.validDensity = kSlabDensities;
    t.youngsModulus = {slabYoungsModulus(density),
                       "E = 0.93 rho^2.8 Pa, van Herwijnen et al. 2016 (J. Glaciol. 62:997)"};
    t.poissonRatio = calibrated(kSlabPoissonRatio);
    t.criticalStateSlope = calibrated(kSlabCriticalStateSlope);
    t.cohesionRatio = calibrated(kSlabCohesionRatio);
    t.tensileStrength = {tensileStrength(density),
                         "sigma_t = 240 kPa (rho/917)^2.44, Sigrist 2006 (ETH thesis)"};
    t.initialP0 = initialP0FromTable(t, kSlabCohesionRatio, kSlabCriticalStateSlope);
    t.hardening = calibrated(kSlabHardening);
    return t;
}

SnowParameterTable weakLayerTable(double density) {
    const double relative = density / kWeakLayerReferenceDensity;
    const double calibratedTension =
        uniaxialTensileStrength(kWeakInitialP0, kWeakCohesionRatio, kWeakCriticalStateSlope);
    SnowParameterTable t;
    t.density = density;
    t.validDensity = kWeakLayerDensities;
    t.youngsModulus = {kWeakYoungsModulus * std::pow(relative, kSlabModulusExponent),
                       "E = 0.48 MPa (rho/100)^2.8: Firn PST calibration at 100 kg/m^3, "
                       "exponent of van Herwijnen et al. 2016"};
    t.poissonRatio = calibrated(kWeakPoissonRatio);
    t.criticalStateSlope = calibrated(kWeakCriticalStateSlope);
    t.cohesionRatio = calibrated(kWeakCohesionRatio);
    t.tensileStrength = {calibratedTension * std::pow(relative, kTensileExponent),
                         "sigma_t = 1.156 kPa (rho/100)^2.44: Firn PST calibration at "
                         "100 kg/m^3, exponent of Sigrist 2006"};
    t.initialP0 = initialP0FromTable(t, kWeakCohesionRatio, kWeakCriticalStateSlope);
    t.hardening = calibrated(kWeakHardening);
    t.softening = calibrated(kWeakSoftening);
    t.softeningLength = {kWeakSofteningLength,
                         "the PST layer alpha was calibrated on (its collapse band fills the "
                         "6 cm at dx >= 0.01); crack band, docs/snow.md"};
    t.dynamicCriticalStateSlope = calibrated(kWeakDynamicCriticalStateSlope);
    return t;
}

} // namespace firn
