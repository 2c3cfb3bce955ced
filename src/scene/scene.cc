// Scene files: TOML text -> overrides -> validated SceneDesc (scene-format.md).
// One small reader per table; every key goes through a TableReader, which checks its type and
// range and reports any key nobody asked for.
#include <firn/scene.h>
#include <firn/scene_keys.h>
#include <firn/snow_parameters.h>

#include "overrides.h"
#include "reader.h"
#include "syntax_error.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace firn {
namespace scene {
namespace {

const Named<Transfer> kTransfers[] = {{"apic", Transfer::Apic},
                                      {"pic", Transfer::Pic},
                                      {"flip", Transfer::Flip},
                                      {"xpic", Transfer::Xpic}};
const Named<MaterialModel> kModels[] = {{"elastic", MaterialModel::Elastic},
                                        {"snow", MaterialModel::Snow},
                                        {"weak_layer", MaterialModel::WeakLayer},
                                        {"granular", MaterialModel::Granular}};
const Named<TerrainShape> kTerrainShapes[] = {{"plane", TerrainShape::Plane},
                                              {"profile", TerrainShape::Profile},
                                              {"heightfield", TerrainShape::Heightfield}};
const Named<Boundary> kBoundaries[] = {{"friction", Boundary::Friction},
                                       {"slip", Boundary::Slip},
                                       {"sticky", Boundary::Sticky},
                                       {"voellmy", Boundary::Voellmy},
                                       {"samosat", Boundary::SamosAT}};
const Named<Saw> kSaws[] = {{"quasi_static", Saw::QuasiStatic}, {"instant", Saw::Instant}};
const Named<BodyShape> kBodyShapes[] = {{"box", BodyShape::Box},
                                        {"sphere", BodyShape::Sphere},
                                        {"layer", BodyShape::Layer},
                                        {"polygon", BodyShape::Polygon}};
const Named<NoDataPolicy> kNoDataPolicies[] = {{"error", NoDataPolicy::Error},
                                               {"fill", NoDataPolicy::Fill}};
const Named<ColorBy> kColorBy[] = {{"density", ColorBy::Density},
                                   {"speed", ColorBy::Speed},
                                   {"failed", ColorBy::Failed},
                                   {"eta", ColorBy::Eta}};

// Which models use a material parameter, as bits indexed by MaterialModel.
constexpr unsigned kElastic = 1u << static_cast<unsigned>(MaterialModel::Elastic);
constexpr unsigned kSnow = 1u << static_cast<unsigned>(MaterialModel::Snow);
constexpr unsigned kWeakLayer = 1u << static_cast<unsigned>(MaterialModel::WeakLayer);
constexpr unsigned kGranular = 1u << static_cast<unsigned>(MaterialModel::Granular);
constexpr unsigned kCamClay = kSnow | kWeakLayer;
constexpr unsigned kAllModels = kElastic | kCamClay | kGranular;

struct MaterialField {
    const char* key;
    double MaterialDesc::*member;
    Range range;
    unsigned models;
    const char* unit;
};

// The material parameters of scene-format.md; their defaults are in MaterialDesc, and for snow
// and weak layers in the snow parameter table (firn/snow_parameters.h).
const MaterialField kMaterialFields[] = {
    {"density", &MaterialDesc::density, Range::positive(), kAllModels, "kg/m^3"},
    {"youngs_modulus", &MaterialDesc::youngsModulus, Range::positive(), kAllModels, "Pa"},
    {"poisson_ratio", &MaterialDesc::poissonRatio, Range::closedOpen(0.0, 0.5), kAllModels, ""},
    {"critical_state_slope", &MaterialDesc::criticalStateSlope, Range::positive(), kCamClay, ""},
    {"cohesion_ratio", &MaterialDesc::cohesionRatio, Range::nonNegative(), kCamClay, ""},
    {"initial_p0", &MaterialDesc::initialP0, Range::positive(), kCamClay, "Pa"},
    {"hardening", &MaterialDesc::hardening, Range::positive(), kCamClay, ""},
    {"softening", &MaterialDesc::softening, Range::nonNegative(), kWeakLayer, ""},
    {"softening_length", &MaterialDesc::softeningLength, Range::nonNegative(), kWeakLayer, "m"},
    {"dynamic_critical_state_slope", &MaterialDesc::dynamicCriticalStateSlope, Range::positive(),
     kWeakLayer, ""},
    {"friction_angle", &MaterialDesc::frictionAngle, Range::open(0.0, 90.0), kGranular, "degrees"},
    {"dynamic_friction_angle", &MaterialDesc::dynamicFrictionAngle, Range::open(0.0, 90.0),
     kGranular, "degrees"},
    {"grain_diameter", &MaterialDesc::grainDiameter, Range::positive(), kGranular, "m"},
    {"inertial_number_scale", &MaterialDesc::inertialNumberScale, Range::positive(), kGranular, ""},
};

// Keys that belong to one shape only; any other shape rejects them.
template <typename Shape> struct ShapeKey {
    Shape shape;
    const char* key;
};

const ShapeKey<TerrainShape> kTerrainShapeKeys[] = {{TerrainShape::Plane, "point"},
                                                    {TerrainShape::Plane, "normal"},
                                                    {TerrainShape::Profile, "points"},
                                                    {TerrainShape::Heightfield, "file"},
                                                    {TerrainShape::Heightfield, "nodata"}};
const ShapeKey<BodyShape> kBodyShapeKeys[] = {{BodyShape::Box, "min"},
                                              {BodyShape::Box, "max"},
                                              {BodyShape::Sphere, "center"},
                                              {BodyShape::Sphere, "radius"},
                                              {BodyShape::Layer, "on_top_of"},
                                              {BodyShape::Layer, "thickness"},
                                              {BodyShape::Layer, "x_range"},
                                              {BodyShape::Layer, "z_range"},
                                              {BodyShape::Layer, "thickness_noise"},
                                              {BodyShape::Layer, "thickness_profile"},
                                              {BodyShape::Polygon, "on_top_of"},
                                              {BodyShape::Polygon, "thickness"},
                                              {BodyShape::Polygon, "thickness_noise"},
                                              {BodyShape::Polygon, "file"},
                                              {BodyShape::Polygon, "thickness_attribute"}};

template <typename Shape, std::size_t N, std::size_t M>
void rejectOtherShapeKeys(TableReader& r, Shape shape, const ShapeKey<Shape> (&keys)[N],
                          const Named<Shape> (&names)[M]) {
    const std::string why = std::string("shape \"") + nameOf(shape, names) + "\"";
    auto ownKey = [&](const char* key) {
        for (const auto& entry : keys)
            if (entry.shape == shape && std::string(entry.key) == key) return true;
        return false;
    };
    for (const auto& entry : keys) {
        if (entry.shape != shape && !ownKey(entry.key)) r.notApplicable(entry.key, why);
    }
}

std::string inQuotes(const std::string& text) {
    return "\"" + text + "\"";
}

std::string namesOrNone(const std::string& names) {
    return names.empty() ? "none" : names;
}

// Index of the entry of `list` called `name` among those `eligible`, or -1; `names` gets the
// eligible names, for the message that lists what could have been meant.
template <typename Desc, typename Eligible>
int indexOfName(const std::vector<Desc>& list, const std::string& name, Eligible eligible,
                std::string& names) {
    for (std::size_t i = 0; i < list.size(); ++i) {
        if (!eligible(list[i])) continue;
        if (list[i].name == name) return static_cast<int>(i);
        names += (names.empty() ? "" : ", ") + list[i].name;
    }
    return -1;
}

template <typename Desc>
void checkUniqueName(TableReader& r, const std::string& name, const std::vector<Desc>& earlier,
                     const char* kind) {
    for (std::size_t i = 0; i < earlier.size(); ++i) {
        if (earlier[i].name != name) continue;
        r.failAt("name", "already used by " + std::string(kind) + " " + std::to_string(i + 1));
    }
}

void readSimulation(TableReader& r, SimulationDesc& sim, SceneContext& context) {
    r.string("name", sim.name);
    r.integer("dimension", sim.dimension, Range::closed(2, 3));
    // Read before any vector: `dimension` decides how many components they must have.
    context.dimension = sim.dimension;
    r.real("end_time", sim.endTime, Range::positive());
    const bool rateGiven = r.real("frame_rate", sim.frameRate, Range::positive());
    // Each frame is two cache files and a metrics row: a slip of the exponent would fill the
    // disk long before the run ends.
    if (sim.endTime * sim.frameRate > kMaxFrames) {
        r.failAt(rateGiven ? "frame_rate" : "end_time",
                 "end_time x frame_rate = " + formatNumber(sim.endTime * sim.frameRate) +
                     " frames; at most " + formatNumber(kMaxFrames) +
                     " (lower frame_rate or end_time)");
    }
    r.vector("gravity", sim.gravity);
    r.integer("seed", sim.seed, Range::nonNegative());
    const bool ramp = r.real("gravity_ramp", sim.gravityRamp, Range::nonNegative());
    const bool settleGiven = r.boolean("settle", sim.settle);
    if (ramp && sim.gravityRamp > 0.0) {
        if (settleGiven && sim.settle)
            r.failAt("settle", "settle = true and gravity_ramp > 0 are two ways to start a scene "
                               "at rest; give one of them");
        sim.settle = false;
    }
    r.real("settle_max_time", sim.settleMaxTime, Range::positive());
    r.real("settle_tolerance", sim.settleTolerance, Range::positive());
    r.real("settle_cfl", sim.settleCfl, Range::openClosed(0.0, 10.0));
    r.boolean("stop_at_rest", sim.stopAtRest);
    if (sim.stopAtRest)
        r.real("rest_energy_fraction", sim.restEnergyFraction, Range::open(0.0, 1.0));
    else
        r.notApplicable("rest_energy_fraction", "stop_at_rest = false");
    const bool minGiven = r.vector("domain_min", sim.domainMin);
    const bool maxGiven = r.vector("domain_max", sim.domainMax);
    if (minGiven != maxGiven)
        r.require({"domain_min", "domain_max"}, "a domain (give both, or neither: unbounded)");
    for (int a = 0; a < sim.dimension && minGiven; ++a)
        if (!(sim.domainMin[a] < sim.domainMax[a]))
            r.failAt("domain_max", "must exceed domain_min in every component");
    if (sim.dimension == 2) { // plane strain: no extent along z
        sim.domainMin[2] = -std::numeric_limits<double>::infinity();
        sim.domainMax[2] = std::numeric_limits<double>::infinity();
    }
    r.finish();
}

/// Whether `key` came from a --set on the command line (it has no line in the scene file).
bool setOnCommandLine(const TableReader& r, std::string_view key) {
    return r.locOf(*r.table().get(key)).line <= 0;
}

void readGrid(TableReader& r, GridDesc& grid) {
    r.real("dx", grid.dx, Range::positive());
    r.integer("particles_per_cell", grid.particlesPerCell, Range::closed(1, 64));
    r.choice("transfer", grid.transfer, kTransfers);
    // Accepted with every transfer, so that --set grid.transfer=apic works on a FLIP scene.
    r.real("flip_blend", grid.flipBlend, Range::closed(0.0, 1.0));
    r.real("flip_relaxation_time", grid.flipRelaxationTime, Range::positive());
    if (r.has("flip_blend") && r.has("flip_relaxation_time")) {
        // Two ways to set the FLIP fraction. A --set of one overrides the other from the file,
        // so that either can be tried on a shipped scene; both in one place is an error.
        const bool blendSet = setOnCommandLine(r, "flip_blend");
        if (blendSet == setOnCommandLine(r, "flip_relaxation_time"))
            r.failAt("flip_relaxation_time",
                     "flip_blend and flip_relaxation_time are two ways to set the FLIP fraction: "
                     "give one");
        if (blendSet) grid.flipRelaxationTime = 0.0;
    }
    r.integer("xpic_order", grid.xpicOrder, Range::closed(1, 16));
    r.real("cfl", grid.cfl, Range::openClosed(0.0, 10.0));
    r.real("max_dt", grid.maxDt, Range::positive());
    r.real("jitter", grid.jitter, Range::closed(0.0, 1.0));
    r.boolean("sleep", grid.sleep);
    r.real("sleep_speed", grid.sleepSpeed, Range::positive());
    r.integer("sleep_steps", grid.sleepSteps, Range::closed(1, 60000));
    r.finish();
}

bool usesField(MaterialModel model, const MaterialField& field) {
    return field.models & (1u << static_cast<unsigned>(model));
}

// "scene file line 12", or "--set" for a value given on the command line.
std::string originOf(const TableReader& r, std::string_view key) {
    const SourceLoc loc = r.locOf(*r.table().get(key));
    return loc.line > 0 ? "scene file line " + std::to_string(loc.line) : loc.file;
}

// A parameter of the snow table and the MaterialDesc field it fills.
struct TableField {
    const char* key;
    double MaterialDesc::*member;
    const TableValue& value;
};

bool given(const MaterialDesc& m, const char* key) {
    return m.origins.count(key) > 0;
}

// A snow or weak-layer material takes every key its scene leaves out from the snow parameter
// table at its density (default: the table's reference density). Outside the table's density
// range that is an error, unless the scene gives every value that depends on density.
void applySnowTable(const TableReader& r, MaterialDesc& m) {
    const bool slab = m.model == MaterialModel::Snow;
    if (!given(m, "density")) m.density = slab ? kSlabReferenceDensity : kWeakLayerReferenceDensity;
    const SnowParameterTable table = slab ? slabTable(m.density) : weakLayerTable(m.density);
    std::string needed;
    for (const char* key : {"youngs_modulus", "initial_p0"}) {
        if (!given(m, key)) needed += (needed.empty() ? "" : " and ") + std::string(key);
    }
    if (!needed.empty() && !table.validDensity.contains(m.density)) {
        r.failAt("density", formatNumber(m.density) +
                                " kg/m^3 is outside the snow parameter table's " +
                                formatNumber(table.validDensity.lo) + "-" +
                                formatNumber(table.validDensity.hi) + " kg/m^3 for model " +
                                inQuotes(toString(m.model)) + ", which would give " + needed +
                                "; give them in the scene or a density inside that range");
    }
    const TableField fields[] = {
        {"youngs_modulus", &MaterialDesc::youngsModulus, table.youngsModulus},
        {"poisson_ratio", &MaterialDesc::poissonRatio, table.poissonRatio},
        {"critical_state_slope", &MaterialDesc::criticalStateSlope, table.criticalStateSlope},
        {"cohesion_ratio", &MaterialDesc::cohesionRatio, table.cohesionRatio},
        {"hardening", &MaterialDesc::hardening, table.hardening},
        {"softening", &MaterialDesc::softening, table.softening},
        {"softening_length", &MaterialDesc::softeningLength, table.softeningLength},
        {"dynamic_critical_state_slope", &MaterialDesc::dynamicCriticalStateSlope,
         table.dynamicCriticalStateSlope},
    };
    for (const TableField& field : fields) {
        if (given(m, field.key) || field.value.source.empty()) continue;
        m.*field.member = field.value.value;
        m.origins[field.key] = "table: " + field.value.source;
    }
    // After beta and M: p0 gives the table's tensile strength with the material's own ellipse.
    if (!given(m, "initial_p0")) {
        if (m.cohesionRatio == 0.0) {
            r.failAt("cohesion_ratio", "0 leaves the ellipse no tensile strength, so initial_p0 "
                                       "cannot follow from the table's; give initial_p0");
        }
        const TableValue p0 = initialP0FromTable(table, m.cohesionRatio, m.criticalStateSlope);
        m.initialP0 = p0.value;
        m.origins["initial_p0"] = "table: " + p0.source;
    }
}

// mu(I): without dynamic_friction_angle the friction is friction_angle at every rate.
void checkRateDependence(TableReader& r, MaterialDesc& m) {
    if (!given(m, "dynamic_friction_angle")) {
        m.dynamicFrictionAngle = m.frictionAngle;
        m.origins["dynamic_friction_angle"] = "default: friction_angle (rate-independent)";
        for (const char* key : {"grain_diameter", "inertial_number_scale"}) {
            if (given(m, key)) {
                r.failAt(key, "has no effect without dynamic_friction_angle (the mu(I) "
                              "friction at large inertial number)");
            }
        }
    } else if (m.dynamicFrictionAngle < m.frictionAngle) {
        r.failAt("dynamic_friction_angle",
                 "must not be below friction_angle (" + formatNumber(m.frictionAngle) +
                     " degrees): mu(I) friction rises with the shear rate");
    }
}

MaterialDesc readMaterial(TableReader& r, const std::vector<MaterialDesc>& earlier) {
    MaterialDesc m;
    m.loc = r.headerLoc();
    r.require({"name", "model"});
    r.string("name", m.name);
    checkUniqueName(r, m.name, earlier, "material");
    r.choice("model", m.model, kModels);
    const std::string why = "model " + inQuotes(toString(m.model));
    for (const auto& field : kMaterialFields) {
        if (!usesField(m.model, field)) {
            r.notApplicable(field.key, why);
        } else if (r.real(field.key, m.*field.member, field.range)) {
            m.origins[field.key] = originOf(r, field.key);
        }
    }
    if (m.model == MaterialModel::Snow || m.model == MaterialModel::WeakLayer) {
        applySnowTable(r, m);
    }
    if (m.model == MaterialModel::Granular) checkRateDependence(r, m);
    r.finish();
    return m;
}

void readPlane(TableReader& r, TerrainDesc& terrain) {
    r.require({"point", "normal"}, "shape \"plane\"");
    r.vector("point", terrain.point);
    r.vector("normal", terrain.normal);
    const Vec3d& n = terrain.normal;
    const double length = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(length > 0.0)) r.failAt("normal", "must not be zero");
    for (double& c : terrain.normal) c /= length;
}

std::string resolvePath(const std::string& folder, const std::string& file) {
    const std::filesystem::path path(file);
    if (path.is_absolute() || folder.empty()) return file;
    return (std::filesystem::path(folder) / path).string();
}

// A file key: the path resolved against the scene's folder, which must name a file.
void readExistingFile(TableReader& r, std::string& file) {
    r.string("file", file);
    file = resolvePath(r.context().folder, file);
    std::error_code error;
    if (!std::filesystem::is_regular_file(file, error)) r.failAt("file", "file not found: " + file);
}

void readHeightfield(TableReader& r, TerrainDesc& terrain) {
    r.require({"file"}, "shape \"heightfield\"");
    if (r.context().dimension != 3) {
        r.failAt("shape", "\"heightfield\" needs dimension = 3");
    }
    readExistingFile(r, terrain.file);
    r.choice("nodata", terrain.noData, kNoDataPolicies);
}

/// A terrain's optional name: what `--set terrain.<name>.friction=0.25` addresses.
struct TerrainName {
    std::string name;
};

TerrainDesc readTerrain(TableReader& r, std::vector<TerrainName>& names) {
    TerrainDesc terrain;
    terrain.loc = r.headerLoc();
    TerrainName named;
    if (r.string("name", named.name)) checkUniqueName(r, named.name, names, "terrain");
    names.push_back(named);
    r.require({"shape"});
    r.choice("shape", terrain.shape, kTerrainShapes);
    if (terrain.shape == TerrainShape::Plane) readPlane(r, terrain);
    if (terrain.shape == TerrainShape::Heightfield) readHeightfield(r, terrain);
    if (terrain.shape == TerrainShape::Profile) {
        r.require({"points"}, "shape \"profile\"");
        r.polyline("points", terrain.points);
    }
    rejectOtherShapeKeys(r, terrain.shape, kTerrainShapeKeys, kTerrainShapes);
    r.choice("boundary", terrain.boundary, kBoundaries);
    const std::string boundaryName = "boundary " + inQuotes(nameOf(terrain.boundary, kBoundaries));
    if (terrain.boundary == Boundary::Voellmy)
        r.real("turbulence", terrain.turbulence, Range::positive());
    else
        r.notApplicable("turbulence", boundaryName);
    const bool samosat = terrain.boundary == Boundary::SamosAT;
    if (samosat) terrain.friction = 0.155; // AvaFrame's standard samosAT calibration
    if (terrain.boundary == Boundary::Friction || terrain.boundary == Boundary::Voellmy || samosat)
        r.real("friction", terrain.friction, Range::nonNegative());
    else
        r.notApplicable("friction", boundaryName);
    const struct {
        const char* key;
        double TerrainDesc::*member;
        Range range;
    } samosatKeys[] = {{"samosat_tau0", &TerrainDesc::samosatTau0, Range::nonNegative()},
                       {"samosat_rs0", &TerrainDesc::samosatRs0, Range::positive()},
                       {"samosat_kappa", &TerrainDesc::samosatKappa, Range::positive()},
                       {"samosat_r", &TerrainDesc::samosatR, Range::positive()},
                       {"samosat_b", &TerrainDesc::samosatB, Range::positive()}};
    for (const auto& k : samosatKeys) {
        if (samosat)
            r.real(k.key, terrain.*k.member, k.range);
        else
            r.notApplicable(k.key, boundaryName);
    }
    r.finish();
    return terrain;
}

std::string formatVector(const Vec3d& v, int dimension) {
    std::string out = "[";
    for (int i = 0; i < dimension; ++i) out += (i ? ", " : "") + formatNumber(v[i]);
    return out + "]";
}

void readBox(TableReader& r, BodyDesc& body) {
    r.require({"min", "max"}, "shape \"box\"");
    r.vector("min", body.min);
    r.vector("max", body.max);
    const int dimension = r.context().dimension;
    for (int i = 0; i < dimension; ++i) {
        if (body.min[i] < body.max[i]) continue;
        r.failAt("max", "must exceed min in every component, got min " +
                            formatVector(body.min, dimension) + ", max " +
                            formatVector(body.max, dimension));
    }
}

void readSphere(TableReader& r, BodyDesc& body) {
    r.require({"center", "radius"}, "shape \"sphere\"");
    r.vector("center", body.center);
    r.real("radius", body.radius, Range::positive());
}

bool isLayer(const BodyDesc& body) {
    return isLayerShape(body.shape) && !body.name.empty();
}

void readLayerSupport(TableReader& r, BodyDesc& body, const std::vector<BodyDesc>& earlier) {
    if (!r.string("on_top_of", body.onTopOf) || body.onTopOf == "ground") return;
    std::string layers;
    if (indexOfName(earlier, body.onTopOf, isLayer, layers) >= 0) return;
    r.failReference("on_top_of", "on_top_of " + inQuotes(body.onTopOf) +
                                     " is neither \"ground\" nor an earlier layer body (layers: " +
                                     namesOrNone(layers) + ")");
}

void readThicknessNoise(TableReader& r, BodyDesc& body) {
    if (auto noise = r.subTable("thickness_noise", r.keyName("thickness_noise") + ".")) {
        noise->real("std", body.thicknessNoise.std, Range::nonNegative());
        noise->real("correlation_length", body.thicknessNoise.correlationLength, Range::positive());
        noise->finish();
    }
}

// `thickness` (m) or `thickness_profile` ([[x, m], ...]), exactly one of them.
void readLayerThickness(TableReader& r, BodyDesc& body) {
    if (r.has("thickness") && r.has("thickness_profile")) {
        r.failAt("thickness_profile", "give thickness or thickness_profile, not both");
    }
    if (!r.has("thickness_profile")) {
        r.require({"thickness"}, "shape \"layer\" (or thickness_profile)");
        r.real("thickness", body.thickness, Range::positive());
        return;
    }
    r.polyline("thickness_profile", body.thicknessProfile, "thickness");
    for (std::size_t k = 0; k < body.thicknessProfile.size(); ++k) {
        if (!(body.thicknessProfile[k][1] > 0.0)) {
            r.failAt("thickness_profile", "point " + std::to_string(k + 1) +
                                              " thickness must be > 0, got " +
                                              formatNumber(body.thicknessProfile[k][1]));
        }
        body.thickness = std::max(body.thickness, body.thicknessProfile[k][1]);
    }
}

void readLayer(TableReader& r, BodyDesc& body, const std::vector<BodyDesc>& earlier) {
    const bool is3d = r.context().dimension == 3;
    r.require({"x_range"}, "shape \"layer\"");
    if (is3d) r.require({"z_range"}, "shape \"layer\"");
    readLayerThickness(r, body);
    r.interval("x_range", body.xRange);
    if (is3d) {
        r.interval("z_range", body.zRange);
    } else {
        r.notApplicable("z_range", "a 2D scene");
    }
    readLayerSupport(r, body, earlier);
    readThicknessNoise(r, body);
}

// Release areas from a vector file: a layer whose footprint is the file's polygons.
void readPolygon(TableReader& r, BodyDesc& body, const std::vector<BodyDesc>& earlier) {
    r.require({"file"}, "shape \"polygon\"");
    if (r.context().dimension != 3) r.failAt("shape", "\"polygon\" needs dimension = 3");
    readExistingFile(r, body.footprintFile);
    r.real("thickness", body.thickness, Range::positive());
    r.string("thickness_attribute", body.thicknessAttribute);
    if (body.thicknessAttribute.empty()) r.failAt("thickness_attribute", "must not be empty");
    readLayerSupport(r, body, earlier);
    readThicknessNoise(r, body);
}

// slides_on: the body lies above a slip surface on an earlier weak-layer body (one per scene);
// slip_friction: that surface's friction once the layer has collapsed.
void readSlipSurface(TableReader& r, BodyDesc& body, const std::vector<MaterialDesc>& materials,
                     const std::vector<BodyDesc>& earlier, Transfer transfer) {
    if (!r.string("slides_on", body.slidesOn)) {
        if (r.has("slip_friction")) r.failAt("slip_friction", "needs slides_on");
        return;
    }
    if (transfer == Transfer::Xpic)
        r.failAt("slides_on", "a slip surface needs grid.transfer \"apic\", \"pic\" or \"flip\" "
                              "(\"xpic\" keeps one velocity field)");
    auto isWeakLayer = [&](const BodyDesc& b) {
        return !b.name.empty() &&
               materials[std::size_t(b.materialIndex)].model == MaterialModel::WeakLayer;
    };
    std::string weakBodies;
    if (indexOfName(earlier, body.slidesOn, isWeakLayer, weakBodies) < 0) {
        r.failReference("slides_on", "slides_on " + inQuotes(body.slidesOn) +
                                         " is not an earlier body of a weak_layer material "
                                         "(such bodies: " +
                                         namesOrNone(weakBodies) + ")");
    }
    r.real("slip_friction", body.slipFriction, Range::nonNegative());
    for (const BodyDesc& other : earlier) {
        if (other.slidesOn.empty()) continue;
        if (other.slidesOn != body.slidesOn) {
            r.failAt("slides_on", "a scene has one slip surface: body " + inQuotes(other.name) +
                                      " slides on " + inQuotes(other.slidesOn));
        }
        if (other.slipFriction >= 0.0 && body.slipFriction >= 0.0 &&
            other.slipFriction != body.slipFriction) {
            r.failAt("slip_friction", "differs from body " + inQuotes(other.name) + "'s " +
                                          formatNumber(other.slipFriction) +
                                          ": a scene has one slip surface");
        }
    }
}

int resolveMaterial(TableReader& r, const std::string& name,
                    const std::vector<MaterialDesc>& materials) {
    std::string names;
    const int index = indexOfName(
        materials, name, [](const MaterialDesc&) { return true; }, names);
    if (index >= 0) return index;
    r.failReference("material", "material " + inQuotes(name) +
                                    " is not defined (materials: " + namesOrNone(names) + ")");
}

BodyDesc readBody(TableReader& r, const std::vector<MaterialDesc>& materials,
                  const std::vector<BodyDesc>& earlier, Transfer transfer) {
    BodyDesc body;
    body.loc = r.headerLoc();
    r.require({"material", "shape"});
    if (r.string("name", body.name)) {
        checkUniqueName(r, body.name, earlier, "body");
        // "ground" is what on_top_of calls the terrain; a body by that name would be ambiguous.
        if (body.name == "ground") r.failAt("name", "\"ground\" is reserved");
    }
    r.string("material", body.material);
    body.materialIndex = resolveMaterial(r, body.material, materials);
    r.choice("shape", body.shape, kBodyShapes);
    r.vector("velocity", body.velocity);
    if (body.shape == BodyShape::Box) readBox(r, body);
    if (body.shape == BodyShape::Sphere) readSphere(r, body);
    if (body.shape == BodyShape::Layer) readLayer(r, body, earlier);
    if (body.shape == BodyShape::Polygon) readPolygon(r, body, earlier);
    readSlipSurface(r, body, materials, earlier, transfer);
    rejectOtherShapeKeys(r, body.shape, kBodyShapeKeys, kBodyShapes);
    r.finish();
    return body;
}

CutDesc readCut(TableReader& r, const std::vector<BodyDesc>& bodies) {
    CutDesc cut;
    cut.loc = r.headerLoc();
    r.require({"layer", "from_x", "length"});
    r.string("layer", cut.layer);
    std::string layers;
    // A cut runs along x across a layer's x_range: polygon bodies have none.
    auto isCuttable = [](const BodyDesc& b) { return b.shape == BodyShape::Layer && isLayer(b); };
    if (indexOfName(bodies, cut.layer, isCuttable, layers) < 0) {
        r.failReference("layer", "layer " + inQuotes(cut.layer) +
                                     " is not a layer body (layers: " + namesOrNone(layers) + ")");
    }
    r.real("from_x", cut.fromX);
    r.real("length", cut.length, Range::positive());
    r.choice("saw", cut.saw, kSaws);
    const BodyDesc& layer = *std::find_if(bodies.begin(), bodies.end(),
                                          [&](const BodyDesc& b) { return b.name == cut.layer; });
    const double x0 = layer.xRange[0], x1 = layer.xRange[1];
    const std::string span = "[" + formatNumber(x0) + ", " + formatNumber(x1) + "]";
    if (cut.length >= x1 - x0) {
        r.failAt("length", formatNumber(cut.length) + " m is not shorter than layer " +
                               inQuotes(cut.layer) + " (x_range " + span +
                               "): the cut would leave nothing of it");
    }
    if (cut.fromX >= x1 || cut.fromX + cut.length <= x0) {
        r.failAt("from_x", "the cut [" + formatNumber(cut.fromX) + ", " +
                               formatNumber(cut.fromX + cut.length) + "] misses layer " +
                               inQuotes(cut.layer) + " (x_range " + span + ")");
    }
    r.finish();
    return cut;
}

void readOutput(TableReader& r, OutputDesc& output, const std::vector<TerrainDesc>& terrains) {
    r.string("directory", output.directory);
    r.boolean("particles", output.particles);
    r.stringList("volumes", output.volumes, {"density", "velocity", "failed", "eta"});
    r.integer("checkpoint_every_frames", output.checkpointEveryFrames, Range::nonNegative());
    r.real("checkpoint_every_minutes", output.checkpointEveryMinutes, Range::nonNegative());
    const bool onDem = std::any_of(terrains.begin(), terrains.end(), [](const TerrainDesc& t) {
        return t.shape == TerrainShape::Heightfield;
    });
    if (r.boolean("rasters", output.rasters) && output.rasters && !onDem)
        r.failAt("rasters", "peak rasters are written on a DEM's grid: the scene has no "
                            "heightfield terrain");
    r.real("raster_cell", output.rasterCell, Range::positive());
    output.loc = r.headerLoc();
    if (r.string("path", output.path)) {
        if (!onDem)
            r.failAt("path", "the runout along a path is measured on the peak pressure raster: "
                             "the scene has no heightfield terrain");
        output.path = resolvePath(r.context().folder, output.path);
        std::error_code error;
        if (!std::filesystem::is_regular_file(output.path, error))
            r.failAt("path", "file not found: " + output.path);
    }
    r.real("runout_pressure", output.runoutPressure, Range::positive());
    r.finish();
}

void readRender(TableReader& r, RenderDesc& render) {
    r.integer("width", render.width, Range::closed(16, 8192));
    r.integer("height", render.height, Range::closed(16, 8192));
    r.choice("color_by", render.colorBy, kColorBy);
    r.interval("color_range", render.colorRange);
    if (r.has("camera_position") || r.has("look_at")) {
        r.require({"camera_position", "look_at"},
                  "a positioned camera (leave both out for the automatic one)");
    }
    render.autoCamera = !r.vector("camera_position", render.cameraPosition);
    r.vector("look_at", render.lookAt);
    r.real("fov_deg", render.fovDeg, Range::open(1.0, 170.0));
    r.integer("contact_frames", render.contactFrames, Range::closed(1, 64));
    r.finish();
}

// Calls readOne with a reader for each [[key]] entry, labelled `key "name"` when `named` and the
// entry has a name, else `key 3` (1-based), as messages name them.
template <typename ReadOne>
void forEachEntry(TableReader& root, const char* key, bool named, ReadOne readOne) {
    const std::vector<const toml::table*> tables = root.tableArray(key);
    for (std::size_t i = 0; i < tables.size(); ++i) {
        const auto* name = named ? tables[i]->get_as<std::string>("name") : nullptr;
        const std::string label =
            name && !name->get().empty() ? inQuotes(name->get()) : std::to_string(i + 1);
        TableReader entry(*tables[i], root.context(), std::string(key) + " " + label + ": ");
        entry.logKeysAs(key);
        readOne(entry);
    }
}

// The reader of the plain table [key], its keys logged under `key`; nullopt when absent.
std::optional<TableReader> section(TableReader& root, const char* key) {
    std::optional<TableReader> t = root.subTable(key, std::string(key) + ".");
    if (t) t->logKeysAs(key);
    return t;
}

SceneDesc readScene(const toml::table& root, const std::string& path, KeyLog* keysRead) {
    SceneDesc scene;
    scene.path = path;
    SceneContext context{path, std::filesystem::path(path).parent_path().string(), 3, keysRead};
    TableReader r(root, context, "");
    // [simulation] first, for its dimension; then each table before those that refer to it.
    if (auto t = section(r, "simulation")) readSimulation(*t, scene.simulation, context);
    if (auto t = section(r, "grid")) readGrid(*t, scene.grid);
    forEachEntry(r, "material", true, [&](TableReader& entry) {
        scene.materials.push_back(readMaterial(entry, scene.materials));
    });
    std::vector<TerrainName> terrainNames;
    forEachEntry(r, "terrain", true, [&](TableReader& entry) {
        scene.terrains.push_back(readTerrain(entry, terrainNames));
    });
    forEachEntry(r, "body", true, [&](TableReader& entry) {
        scene.bodies.push_back(readBody(entry, scene.materials, scene.bodies, scene.grid.transfer));
    });
    forEachEntry(r, "cut", false,
                 [&](TableReader& entry) { scene.cuts.push_back(readCut(entry, scene.bodies)); });
    if (auto t = section(r, "output")) readOutput(*t, scene.output, scene.terrains);
    if (scene.output.directory.empty()) scene.output.directory = "out/" + scene.simulation.name;
    if (auto t = section(r, "render")) readRender(*t, scene.render);
    r.finish();
    return scene;
}

// The as-run copy of a scene (outputs.md) lives in another folder than the scene: its terrain
// files are written as absolute paths so that the copy loads, and repeats the run, from there.
void absoluteTerrainFiles(toml::table& root, const SceneDesc& desc) {
    toml::array* terrains = root["terrain"].as_array();
    for (std::size_t i = 0; terrains && i < terrains->size() && i < desc.terrains.size(); ++i) {
        toml::table* terrain = (*terrains)[i].as_table();
        if (terrain && terrain->contains("file")) {
            terrain->insert_or_assign(
                "file",
                std::filesystem::absolute(desc.terrains[i].file).lexically_normal().string());
        }
    }
    toml::array* bodies = root["body"].as_array();
    for (std::size_t i = 0; bodies && i < bodies->size() && i < desc.bodies.size(); ++i) {
        toml::table* body = (*bodies)[i].as_table();
        if (body && body->contains("file")) {
            body->insert_or_assign("file", std::filesystem::absolute(desc.bodies[i].footprintFile)
                                               .lexically_normal()
                                               .string());
        }
    }
    toml::table* output = root["output"].as_table();
    if (output && output->contains("path"))
        output->insert_or_assign(
            "path", std::filesystem::absolute(desc.output.path).lexically_normal().string());
}

// A --set of flip_blend or flip_relaxation_time overrides the other from the file (readGrid):
// the as-run copy keeps only the one in force, so that it reads back.
void dropOverriddenKeys(toml::table& root, const SceneDesc& desc) {
    toml::table* grid = root["grid"].as_table();
    if (grid && grid->contains("flip_blend") && grid->contains("flip_relaxation_time"))
        grid->erase(desc.grid.flipRelaxationTime > 0 ? "flip_blend" : "flip_relaxation_time");
}

toml::table parseDocument(const std::string& text, const std::string& path) {
    try {
        return toml::parse(text, std::string_view(path));
    } catch (const toml::parse_error& e) {
        const auto& at = e.source().begin;
        throw syntaxError(text, path, static_cast<int>(at.line), static_cast<int>(at.column),
                          std::string(e.description()));
    }
}

} // namespace
} // namespace scene

SceneDesc parseScene(const std::string& text, const std::string& path,
                     const std::vector<std::string>& overrides) {
    toml::table root = scene::parseDocument(text, path);
    scene::applyOverrides(root, overrides);
    SceneDesc desc = scene::readScene(root, path, nullptr);
    scene::absoluteTerrainFiles(root, desc);
    scene::dropOverriddenKeys(root, desc);
    // No multi-line or literal strings: toml++ 3.3 writes a string that starts with a newline
    // as a multi-line one, whose first newline TOML drops on reading (found by fuzzing).
    std::ostringstream resolved;
    resolved << toml::toml_formatter{root, toml::toml_formatter::default_flags &
                                               ~(toml::format_flags::allow_multi_line_strings |
                                                 toml::format_flags::allow_literal_strings)};
    desc.resolvedToml = resolved.str();
    return desc;
}

namespace scene {
namespace {
std::string readSceneText(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw SceneError(SourceLoc{path, 0, 0}, "", "cannot open scene file");
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}
} // namespace
} // namespace scene

SceneDesc loadScene(const std::string& path, const std::vector<std::string>& overrides) {
    return parseScene(scene::readSceneText(path), path, overrides);
}

std::map<std::string, std::set<std::string>>
sceneKeysRead(const std::string& path, const std::vector<std::string>& overrides) {
    toml::table root = scene::parseDocument(scene::readSceneText(path), path);
    scene::applyOverrides(root, overrides);
    scene::KeyLog log;
    scene::readScene(root, path, &log);
    return {log.begin(), log.end()};
}

std::vector<MaterialParameter> materialParameters(const MaterialDesc& material) {
    std::vector<MaterialParameter> parameters;
    for (const auto& field : scene::kMaterialFields) {
        if (!scene::usesField(material.model, field)) continue;
        const auto origin = material.origins.find(field.key);
        parameters.push_back({field.key, material.*field.member, field.unit,
                              origin == material.origins.end() ? "default" : origin->second});
    }
    return parameters;
}

const char* toString(ColorBy colorBy) {
    return scene::nameOf(colorBy, scene::kColorBy);
}

bool parseColorBy(const std::string& word, ColorBy& out) {
    for (const auto& n : scene::kColorBy) {
        if (word == n.name) {
            out = n.value;
            return true;
        }
    }
    return false;
}

const char* toString(Transfer transfer) {
    return scene::nameOf(transfer, scene::kTransfers);
}

const char* toString(MaterialModel model) {
    return scene::nameOf(model, scene::kModels);
}

} // namespace firn
