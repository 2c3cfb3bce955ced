// The snow parameter table: the Cam-Clay parameters of a slab (`model = "snow"`) and a weak
// layer (`model = "weak_layer"`) as functions of density, each value with its source. A scene
// may give such a material by its density alone; every key it leaves out comes from here
// (docs/snow.md, parameter table). Pure functions, no scene or solver state.
#pragma once

#include <string>

namespace firn {

/// One value of the table and where it comes from (a law with its citation, or a calibration).
struct TableValue {
    double value = 0.0;
    std::string source;
};

/// Densities, kg/m^3, inside which the table's density laws are used.
struct DensityRange {
    double lo = 0.0;
    double hi = 0.0;
    bool contains(double density) const { return density >= lo && density <= hi; }
};

/// The Cam-Clay parameters of one material at one density (units as in MaterialDesc).
struct SnowParameterTable {
    double density = 0.0;                 ///< kg/m^3, the density the table was evaluated at
    DensityRange validDensity;            ///< where the density-dependent values may be used
    TableValue youngsModulus;             ///< Pa, depends on density
    TableValue poissonRatio;              ///< constant
    TableValue criticalStateSlope;        ///< M, constant
    TableValue cohesionRatio;             ///< beta, constant
    TableValue tensileStrength;           ///< Pa, uniaxial; depends on density
    TableValue initialP0;                 ///< Pa, from tensileStrength with this beta and M
    TableValue hardening;                 ///< xi, constant
    TableValue softening;                 ///< alpha, weak layer only (0 and no source for a slab)
    TableValue softeningLength;           ///< m, weak layer only: where alpha was calibrated
    TableValue dynamicCriticalStateSlope; ///< M_d, weak layer only (0 and no source for a slab)
};

/// Density at which a slab's table is evaluated when the scene gives none, kg/m^3.
constexpr double kSlabReferenceDensity = 250.0;
/// Density of the calibrated PST weak layer, the weak layer's default, kg/m^3.
constexpr double kWeakLayerReferenceDensity = 100.0;

/// Slab Young's modulus, Pa: E = 0.93 rho^2.8 (rho in kg/m^3), van Herwijnen et al. 2016
/// (J. Glaciol. 62(236):997-1007), fitted to the slab moduli of 80 field PSTs.
double slabYoungsModulus(double density);

/// Tensile strength of snow, Pa: sigma_t = 240 kPa (rho / 917)^2.44, Sigrist 2006 (PhD thesis,
/// ETH Zurich), as eq. 22 of Weissgraeber and Rosendahl 2023 (The Cryosphere 17:1475).
double tensileStrength(double density);

/// Uniaxial tensile strength of the Cam-Clay ellipse of eq. (1) in 3D invariants, Pa: the
/// uniaxial tension sigma at which y(p, q) = 0 with p = -sigma/3, q = sigma (derivation in the
/// .cc). Its mean stress sigma/3 stays below the tensile tip's beta p0, reaching it as M grows.
double uniaxialTensileStrength(double p0, double beta, double M);

/// The p0 whose ellipse has uniaxial tensile strength `sigmaT` (inverse of the above; the
/// strength is proportional to p0 for fixed beta and M).
double p0FromUniaxialTensileStrength(double sigmaT, double beta, double M);

/// initial_p0 of a material whose uniaxial tensile strength is the table's, with the material's
/// own beta and M (those of the table, or those the scene gives).
TableValue initialP0FromTable(const SnowParameterTable& table, double beta, double M);

/// The slab (`model = "snow"`) at `density`. No range check: see validDensity.
SnowParameterTable slabTable(double density);

/// The weak layer (`model = "weak_layer"`) at `density`; at kWeakLayerReferenceDensity exactly
/// the calibrated PST weak layer of scenes/pst.toml. No range check: see validDensity.
SnowParameterTable weakLayerTable(double density);

} // namespace firn
