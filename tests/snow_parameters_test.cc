// The snow parameter table (firn/snow_parameters.h) at single points: the published laws'
// values, the ellipse's uniaxial tensile strength, the calibrated weak layer, monotonicity,
// sources and ranges; then how a scene takes its missing keys from it.
#include <firn/material.h>
#include <firn/scene.h>
#include <firn/snow_parameters.h>

#include <catch2/catch.hpp>

#include <string>

using namespace firn;

namespace {

bool contains(const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
}

// y(p, q) of eq. (1) in double precision, for the ellipse tests.
double yieldFunction(double p, double q, double p0, double M, double beta) {
    return (1.0 + 2.0 * beta) * q * q + M * M * (p + beta * p0) * (p - p0);
}

const char* const kPath = "scenes/test.toml";

SceneDesc parse(const std::string& materials, const std::vector<std::string>& overrides = {}) {
    return parseScene("[grid]\ndx = 0.1\n\n" + materials, kPath, overrides);
}

std::string errorOf(const std::string& materials) {
    try {
        parse(materials);
    } catch (const SceneError& e) {
        return e.what();
    }
    return "no error";
}

} // namespace

TEST_CASE("The slab's Young's modulus is van Herwijnen et al. 2016's law", "[snow_parameters]") {
    // E = 0.93 rho^2.8 Pa, evaluated by hand: 250^2.8 = exp(2.8 ln 250) = 5.17883e6.
    CHECK(slabYoungsModulus(250.0) == Approx(4.81632e6).epsilon(1e-5));
    CHECK(slabYoungsModulus(150.0) == Approx(1.15223e6).epsilon(1e-5));
    CHECK(slabYoungsModulus(350.0) == Approx(12.3559e6).epsilon(1e-5));
    CHECK(slabTable(250.0).youngsModulus.value == slabYoungsModulus(250.0));
}

TEST_CASE("Tensile strength is Sigrist 2006's law", "[snow_parameters]") {
    CHECK(tensileStrength(917.0) == Approx(240.0e3).epsilon(1e-12)); // at ice density
    CHECK(tensileStrength(250.0) == Approx(10069.4).epsilon(1e-5));
    CHECK(tensileStrength(200.0) == Approx(5841.75).epsilon(1e-5));
}

TEST_CASE("The ellipse's uniaxial tensile strength lies on the yield surface",
          "[snow_parameters]") {
    for (const double beta : {0.1, 0.3, 0.5, 1.0}) {
        for (const double M : {0.5, 0.85, 1.0, 2.0}) {
            const double p0 = 1.0e4;
            const double sigma = uniaxialTensileStrength(p0, beta, M);
            INFO("beta " << beta << ", M " << M << ", sigma " << sigma);
            CHECK(sigma > 0.0);
            // Uniaxial tension sigma: p = -sigma/3, q = sigma (3D invariants of snow-model.md).
            CHECK(yieldFunction(-sigma / 3.0, sigma, p0, M, beta) ==
                  Approx(0.0).margin(1e-9 * p0 * p0));
            // Its mean stress stays inside the tensile tip: sigma/3 < beta p0.
            CHECK(sigma / 3.0 < beta * p0);
            CHECK(p0FromUniaxialTensileStrength(sigma, beta, M) == Approx(p0).epsilon(1e-12));
            // The solver's own yield function agrees (single precision).
            CHECK(camClayYield(float(-sigma / 3.0), float(sigma), float(p0), float(M),
                               float(beta)) == Approx(0.0).margin(1e-5 * p0 * p0));
        }
    }
    // Slab numbers of docs/snow.md: 0.4488 p0 for beta 0.5, M 1; the shipped slab's 26.9 kPa.
    CHECK(uniaxialTensileStrength(1.0, 0.5, 1.0) == Approx(0.448789).epsilon(1e-5));
    CHECK(uniaxialTensileStrength(6.0e4, 0.5, 1.0) == Approx(26927.3).epsilon(1e-5));
    // As M grows the uniaxial state reaches the tensile tip: sigma -> 3 beta p0.
    CHECK(uniaxialTensileStrength(1.0, 0.5, 1.0e4) == Approx(1.5).epsilon(1e-6));
}

TEST_CASE("The slab table at 250 kg/m^3", "[snow_parameters]") {
    const SnowParameterTable t = slabTable(250.0);
    CHECK(t.density == 250.0);
    CHECK(t.poissonRatio.value == 0.2);
    CHECK(t.criticalStateSlope.value == 1.0);
    CHECK(t.cohesionRatio.value == 0.5);
    CHECK(t.hardening.value == 0.5);
    CHECK(t.tensileStrength.value == tensileStrength(250.0));
    // p0 = sigma_t / 0.448789 = 22.437 kPa: the ellipse's uniaxial strength is Sigrist's.
    CHECK(t.initialP0.value == Approx(22436.8).epsilon(1e-5));
    CHECK(uniaxialTensileStrength(t.initialP0.value, 0.5, 1.0) ==
          Approx(t.tensileStrength.value).epsilon(1e-12));
    CHECK(t.softening.source.empty()); // a slab has no weak-layer parameters
    CHECK(t.softeningLength.source.empty());
    CHECK(t.dynamicCriticalStateSlope.source.empty());
}

TEST_CASE("The weak layer table at 100 kg/m^3 is the calibrated PST weak layer",
          "[snow_parameters]") {
    const SnowParameterTable t = weakLayerTable(kWeakLayerReferenceDensity);
    CHECK(t.youngsModulus.value == Approx(4.8e5).epsilon(1e-12));
    CHECK(t.poissonRatio.value == 0.2);
    CHECK(t.criticalStateSlope.value == 0.85);
    CHECK(t.cohesionRatio.value == 0.1);
    CHECK(t.initialP0.value == Approx(6900.0).epsilon(1e-12));
    CHECK(t.hardening.value == 0.015);
    CHECK(t.softening.value == 100.0);
    CHECK(t.softeningLength.value == 0.06); // the PST layer's thickness
    CHECK(t.dynamicCriticalStateSlope.value == 1.2);
    // Its uniaxial tensile strength, and Sigrist's law at the same density within 7 %.
    CHECK(t.tensileStrength.value == Approx(1156.01).epsilon(1e-5));
    CHECK(tensileStrength(100.0) == Approx(t.tensileStrength.value).epsilon(0.07));
    // Away from 100 kg/m^3 the laws' exponents: twice the density, 2^2.8 and 2^2.44.
    const SnowParameterTable twice = weakLayerTable(200.0);
    CHECK(twice.youngsModulus.value == Approx(4.8e5 * 6.96440).epsilon(1e-5));
    CHECK(twice.initialP0.value == Approx(6900.0 * 5.42641).epsilon(1e-5));
}

TEST_CASE("Stiffness and strength grow with density, the rest does not change",
          "[snow_parameters]") {
    for (const auto table : {&slabTable, &weakLayerTable}) {
        const DensityRange range = table(250.0).validDensity;
        SnowParameterTable previous = table(range.lo);
        for (double rho = range.lo + 10.0; rho <= range.hi; rho += 10.0) {
            const SnowParameterTable t = table(rho);
            INFO("density " << rho);
            CHECK(t.youngsModulus.value > previous.youngsModulus.value);
            CHECK(t.tensileStrength.value > previous.tensileStrength.value);
            CHECK(t.initialP0.value > previous.initialP0.value);
            CHECK(t.criticalStateSlope.value == previous.criticalStateSlope.value);
            CHECK(t.cohesionRatio.value == previous.cohesionRatio.value);
            CHECK(t.hardening.value == previous.hardening.value);
            previous = t;
        }
    }
}

TEST_CASE("Every table value names its source", "[snow_parameters]") {
    const SnowParameterTable slab = slabTable(250.0);
    CHECK(contains(slab.youngsModulus.source, "0.93 rho^2.8"));
    CHECK(contains(slab.youngsModulus.source, "van Herwijnen et al. 2016"));
    CHECK(contains(slab.tensileStrength.source, "240 kPa (rho/917)^2.44, Sigrist 2006"));
    CHECK(contains(slab.initialP0.source, "Sigrist 2006"));
    CHECK(contains(slab.initialP0.source, "ellipse"));
    for (const TableValue* v :
         {&slab.poissonRatio, &slab.criticalStateSlope, &slab.cohesionRatio, &slab.hardening})
        CHECK(v->source == "Firn PST calibration, docs/snow.md");
    const SnowParameterTable weak = weakLayerTable(100.0);
    CHECK(contains(weak.youngsModulus.source, "Firn PST calibration at 100 kg/m^3"));
    CHECK(contains(weak.youngsModulus.source, "van Herwijnen et al. 2016"));
    CHECK(contains(weak.initialP0.source, "Sigrist 2006"));
    CHECK(weak.softening.source == "Firn PST calibration, docs/snow.md");
}

TEST_CASE("The tables' density ranges", "[snow_parameters]") {
    const DensityRange slab = slabTable(250.0).validDensity;
    CHECK(slab.lo == 60.0);
    CHECK(slab.hi == 500.0);
    CHECK(slab.contains(kSlabReferenceDensity));
    CHECK_FALSE(slab.contains(59.9));
    CHECK_FALSE(slab.contains(500.1));
    const DensityRange weak = weakLayerTable(100.0).validDensity;
    CHECK(weak.lo == 60.0);
    CHECK(weak.hi == 200.0);
    CHECK(weak.contains(kWeakLayerReferenceDensity));
}

TEST_CASE("A slab and weak layer given by density alone take the table",
          "[scene][snow_parameters]") {
    const SceneDesc scene = parse(R"([[material]]
name = "slab"
model = "snow"
density = 300

[[material]]
name = "weak"
model = "weak_layer"
)");
    REQUIRE(scene.materials.size() == 2);
    const MaterialDesc& slab = scene.materials[0];
    const SnowParameterTable t = slabTable(300.0);
    CHECK(slab.density == 300.0);
    CHECK(slab.youngsModulus == t.youngsModulus.value);
    CHECK(slab.poissonRatio == t.poissonRatio.value);
    CHECK(slab.criticalStateSlope == t.criticalStateSlope.value);
    CHECK(slab.cohesionRatio == t.cohesionRatio.value);
    CHECK(slab.initialP0 == Approx(t.initialP0.value).epsilon(1e-12));
    CHECK(slab.hardening == t.hardening.value);
    CHECK(slab.origins.at("density") == "scene file line 7");
    CHECK(slab.origins.at("youngs_modulus") == "table: " + t.youngsModulus.source);
    CHECK(slab.origins.at("initial_p0") == "table: " + t.initialP0.source);
    CHECK(slab.origins.at("hardening") == "table: Firn PST calibration, docs/snow.md");

    // No density: the calibrated weak layer at 100 kg/m^3, its density by default.
    const MaterialDesc& weak = scene.materials[1];
    CHECK(weak.density == 100.0);
    CHECK(weak.youngsModulus == Approx(4.8e5).epsilon(1e-12));
    CHECK(weak.initialP0 == Approx(6900.0).epsilon(1e-12));
    CHECK(weak.softening == 100.0);
    CHECK(weak.softeningLength == 0.06);
    CHECK(weak.dynamicCriticalStateSlope == 1.2);
    const std::vector<MaterialParameter> shown = materialParameters(weak);
    REQUIRE(shown.size() == 10);
    CHECK(std::string(shown[0].key) == "density");
    CHECK(shown[0].origin == "default");
    CHECK(std::string(shown[5].key) == "initial_p0");
    CHECK(std::string(shown[5].unit) == "Pa");
    CHECK(shown[5].value == weak.initialP0);
    CHECK(contains(shown[5].origin, "table: "));
}

TEST_CASE("A key given in the scene wins over the table", "[scene][snow_parameters]") {
    const SceneDesc scene = parse(R"([[material]]
name = "slab"
model = "snow"
density = 200
youngs_modulus = 7.0e6
cohesion_ratio = 0.3
)",
                                  {"material.slab.hardening=0.7"});
    const MaterialDesc& slab = scene.materials[0];
    CHECK(slab.youngsModulus == 7.0e6);
    CHECK(slab.origins.at("youngs_modulus") == "scene file line 8");
    CHECK(slab.hardening == 0.7);
    CHECK(slab.origins.at("hardening") == "--set");
    CHECK(slab.poissonRatio == 0.2);
    CHECK(contains(slab.origins.at("poisson_ratio"), "table: "));
    // p0 follows the tensile strength on the material's own ellipse (beta 0.3, not 0.5).
    CHECK(slab.cohesionRatio == 0.3);
    CHECK(uniaxialTensileStrength(slab.initialP0, 0.3, 1.0) ==
          Approx(tensileStrength(200.0)).epsilon(1e-12));
    CHECK(slab.initialP0 != Approx(slabTable(200.0).initialP0.value));
}

TEST_CASE("A density outside the table is an error unless the scene gives what depends on it",
          "[scene][snow_parameters]") {
    CHECK(errorOf("[[material]]\nname = \"slab\"\nmodel = \"snow\"\ndensity = 550\n") ==
          "scenes/test.toml:7:11: error: material \"slab\": density: 550 kg/m^3 is outside the "
          "snow parameter table's 60-500 kg/m^3 for model \"snow\", which would give "
          "youngs_modulus and initial_p0; give them in the scene or a density inside that range");
    CHECK(errorOf("[[material]]\nname = \"weak\"\nmodel = \"weak_layer\"\ndensity = 250\n"
                  "initial_p0 = 5000\n") ==
          "scenes/test.toml:7:11: error: material \"weak\": density: 250 kg/m^3 is outside the "
          "snow parameter table's 60-200 kg/m^3 for model \"weak_layer\", which would give "
          "youngs_modulus; give them in the scene or a density inside that range");
    CHECK(errorOf("[[material]]\nname = \"slab\"\nmodel = \"snow\"\ncohesion_ratio = 0\n") ==
          "scenes/test.toml:7:18: error: material \"slab\": cohesion_ratio: 0 leaves the ellipse "
          "no tensile strength, so initial_p0 cannot follow from the table's; give initial_p0");
    const SceneDesc given = parse("[[material]]\nname = \"slab\"\nmodel = \"snow\"\n"
                                  "density = 550\nyoungs_modulus = 2e7\ninitial_p0 = 1e5\n");
    CHECK(given.materials[0].hardening == 0.5); // density-free values still from the table
}

TEST_CASE("Elastic and granular materials keep their defaults", "[scene][snow_parameters]") {
    const SceneDesc scene = parse("[[material]]\nname = \"block\"\nmodel = \"elastic\"\n\n"
                                  "[[material]]\nname = \"sand\"\nmodel = \"granular\"\n");
    for (const MaterialDesc& m : scene.materials) {
        CHECK(m.density == 250.0);
        CHECK(m.youngsModulus == 1.0e6);
        CHECK(m.poissonRatio == 0.3);
        for (const MaterialParameter& p : materialParameters(m)) {
            // mu(I)'s angle at large inertial number follows friction_angle unless given.
            CHECK(p.origin == (std::string(p.key) == "dynamic_friction_angle"
                                   ? "default: friction_angle (rate-independent)"
                                   : "default"));
        }
    }
    CHECK(scene.materials[1].frictionAngle == 30.0);
    CHECK(scene.materials[1].dynamicFrictionAngle == 30.0);
}
