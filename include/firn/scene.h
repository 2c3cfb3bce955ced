// Scene description: the plain structs a TOML scene file is parsed into.
// Parsing knows nothing of OpenVDB; the solver knows nothing of TOML (design.md).
#pragma once

#include <firn/dem.h>
#include <firn/errors.h>

#include <array>
#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <vector>

namespace firn {

using Vec3d = std::array<double, 3>;

enum class Transfer { Apic, Pic, Flip, Xpic };
enum class MaterialModel { Elastic, Snow, WeakLayer, Granular };
enum class TerrainShape { Plane, Profile, Heightfield };
enum class Boundary { Friction, Slip, Sticky, Voellmy, SamosAT };
/// How a saw cut is made: before the snowpack settles (a field saw takes seconds: the overhang
/// takes its load quasi-statically) or all at once on the settled column (a sudden release whose
/// dynamic overshoot of the overhang's bending lowers the critical cut length).
enum class Saw { QuasiStatic, Instant };
enum class BodyShape { Box, Sphere, Layer, Polygon };
enum class ColorBy { Density, Speed, Failed, Eta };

/// The most frames a scene may ask for (simulation.end_time x frame_rate).
constexpr double kMaxFrames = 1e6;

/// [simulation]
struct SimulationDesc {
    std::string name = "scene";
    int dimension = 3;                 ///< 2 (plane strain) or 3
    double endTime = 1.0;              ///< s
    double frameRate = 24.0;           ///< frames per simulated second
    Vec3d gravity = {0.0, -9.81, 0.0}; ///< m/s^2; z is 0 in 2D
    std::uint64_t seed = 1;
    /// s: gravity grows linearly from 0 to full over this time, so that bodies seeded without
    /// stress settle quasi-statically instead of bouncing (0: full gravity from the start).
    double gravityRamp = 0.0;
    /// Start at rest: before t = 0 the scene settles under full gravity into static
    /// equilibrium (elastically, frictional contacts held, kinetic damping; src/settle). On by
    /// default; off when gravity_ramp is given (the two are alternative ways to start).
    bool settle = true;
    double settleMaxTime = 2.0;    ///< s of simulated settling at most
    double settleTolerance = 1e-6; ///< settled when a kinetic-energy peak < this x elastic energy
    /// CFL number while settling; 0: derived (settlingCfl), the largest the stability map
    /// measured stable for APIC at the scene's particle density.
    double settleCfl = 0.0;
    /// End the run once the flow has stopped (RestDetector, firn/hazard.h): its kinetic energy
    /// below restEnergyFraction of its peak, after the centre of mass has moved one cell.
    bool stopAtRest = true;
    double restEnergyFraction = 0.01; ///< AvaFrame's stopCrit
    /// The simulated region, m: snow that leaves it (off the edge of a DEM, falling past the
    /// terrain) is removed at the end of the frame and counted as outflow. Unbounded where a
    /// component is infinite (the default: nothing is removed).
    Vec3d domainMin = {-std::numeric_limits<double>::infinity(),
                       -std::numeric_limits<double>::infinity(),
                       -std::numeric_limits<double>::infinity()};
    Vec3d domainMax = {std::numeric_limits<double>::infinity(),
                       std::numeric_limits<double>::infinity(),
                       std::numeric_limits<double>::infinity()};
};

/// [grid]
struct GridDesc {
    double dx = 0.05; ///< m
    int particlesPerCell = 8;
    Transfer transfer = Transfer::Apic;
    double flipBlend = 0.95; ///< FLIP fraction, only for Transfer::Flip
    /// s; > 0 replaces flipBlend by exp(-dt / flipRelaxationTime) each step, so that the
    /// particles' noise relaxes toward the grid velocity at a rate per second, not per step.
    double flipRelaxationTime = 0.0;
    /// XPIC(m) (Hammerquist & Nairn 2017): m - 1 extra particle round trips a step filter the
    /// particles' velocity toward its projection on the grid; 1 is PIC.
    int xpicOrder = 2;
    double cfl = 0.4;
    /// s; none by default: the CFL condition alone sets the step (docs/reference/scene.md,
    /// grid.max_dt).
    double maxDt = std::numeric_limits<double>::infinity();
    double jitter = 0.5; ///< fraction of a sub-cell by which seeds are jittered
    /// Resting snow sleeps: particles of a leaf whose snow, and its neighbours', has stayed below
    /// sleepSpeed for sleepSteps steps skip G2P and plasticity until a moving neighbour wakes it.
    bool sleep = true;
    double sleepSpeed = 0.02; ///< m/s
    int sleepSteps = 100;
};

/// [[material]]; defaults are those of scene-format.md. For `snow` and `weak_layer` the scene
/// reader replaces them with the snow parameter table at the material's density
/// (firn/snow_parameters.h); the values below are then only those of a MaterialDesc built in code.
struct MaterialDesc {
    std::string name;
    MaterialModel model = MaterialModel::Elastic;
    double density = 250.0;       ///< kg/m^3
    double youngsModulus = 1.0e6; ///< Pa
    double poissonRatio = 0.3;
    double criticalStateSlope = 1.0; ///< M
    double cohesionRatio = 0.3;      ///< beta
    double initialP0 = 2.0e4;        ///< Pa
    double hardening = 5.0;          ///< xi
    double softening = 1.0;          ///< alpha (weak layer)
    /// m (weak layer): the thickness of failing layer that `softening` was measured for; where
    /// the band a collapse leaves (kCrackBandCells cells) is thinner, alpha is scaled down with it
    /// (crack band). 0: alpha as given at any dx.
    double softeningLength = 0.0;
    double dynamicCriticalStateSlope = 1.2; ///< M_d (weak layer)
    double frictionAngle = 30.0;            ///< degrees (granular; at rest with mu(I))
    /// Granular mu(I) rheology: the friction angle at large inertial number (degrees); the
    /// reader sets it to frictionAngle when absent, which makes the friction rate-independent.
    double dynamicFrictionAngle = 30.0;
    double grainDiameter = 1.0e-3;      ///< m (granular mu(I): d in I)
    double inertialNumberScale = 0.279; ///< I_0 of mu(I) (Jop et al. 2006, glass beads)
    SourceLoc loc;
    /// Where each parameter's value came from, by scene key: "scene file line 12", "--set",
    /// "table: <law, citation>" or "default" (a key absent here is "default").
    std::map<std::string, std::string> origins;
};

/// One material parameter as `firn check` shows it.
struct MaterialParameter {
    const char* key;  ///< scene key, "youngs_modulus"
    double value;     ///< as the simulation uses it
    const char* unit; ///< "Pa", "kg/m^3", "" for ratios, "degrees"
    std::string origin;
};

/// The parameters `material`'s model uses, in the order of the scene reference, with their
/// values and origins.
std::vector<MaterialParameter> materialParameters(const MaterialDesc& material);

/// [[terrain]]
struct TerrainDesc {
    TerrainShape shape = TerrainShape::Plane;
    Vec3d point = {0.0, 0.0, 0.0};             ///< plane
    Vec3d normal = {0.0, 1.0, 0.0};            ///< plane, normalised on read
    std::vector<std::array<double, 2>> points; ///< profile: (x, y), x strictly increasing
    std::string file; ///< heightfield: path resolved against the scene's folder
    NoDataPolicy noData = NoDataPolicy::Error; ///< heightfield: what NODATA cells become
    /// heightfield: the local frame's origin (SceneDesc::frameOrigin), subtracted from the DEM's
    /// coordinates as it is read; set by toLocalFrame (firn/gis.h), not a scene key.
    Vec3d fileOrigin = {0.0, 0.0, 0.0};
    Boundary boundary = Boundary::Friction;
    /// Coulomb coefficient mu (friction, voellmy and samosat; samosat's default is AvaFrame's
    /// 0.155, set by the parser when the scene gives none)
    double friction = 0.4;
    /// voellmy: the turbulent friction coefficient xi, m/s^2 (RAMMS: 1000-4000 for dense flows)
    double turbulence = 2000.0;
    /// samosat: AvaFrame's standard calibration of the law's other coefficients (Sampl and
    /// Zwinger 2004; AvaFrame com1DFA, `tau0`, `Rs0`, `kappa`, `R`, `B`)
    double samosatTau0 = 0.0;   ///< Pa, the minimum shear stress
    double samosatRs0 = 0.222;  ///< the Coulomb term's speed scale (dimensionless)
    double samosatKappa = 0.43; ///< the turbulent term's von Karman-like constant
    double samosatR = 0.05;     ///< m, the turbulent term's roughness length
    double samosatB = 4.13;     ///< the turbulent term's offset
    SourceLoc loc;
};

/// thickness_noise = { std, correlation_length } of a layer body.
struct LayerNoiseDesc {
    double std = 0.0;                ///< fraction of the thickness
    double correlationLength = 10.0; ///< m
};

/// [[body]]
struct BodyDesc {
    std::string name; ///< optional, so that a layer can sit on it
    std::string material;
    int materialIndex = -1; ///< resolved index into SceneDesc::materials
    BodyShape shape = BodyShape::Box;
    Vec3d min = {0, 0, 0}, max = {0, 0, 0}; ///< box
    Vec3d center = {0, 0, 0};               ///< sphere
    double radius = 0.0;                    ///< sphere
    Vec3d velocity = {0, 0, 0};             ///< m/s
    std::string onTopOf = "ground"; ///< layer, polygon: "ground" or the name of another layer body
    double thickness = 0.0; ///< layer, polygon, m, normal to the ground (polygon: 0 = attribute)
    std::array<double, 2> xRange = {0, 0};
    std::array<double, 2> zRange = {0, 0};
    /// layer: [[x, thickness], ...] (m): the thickness along x, linear between the points and
    /// constant past the ends; replaces `thickness` (a slab deepest mid-path, Gaume et al. 2019).
    std::vector<std::array<double, 2>> thicknessProfile;
    LayerNoiseDesc thicknessNoise;
    /// polygon: a vector file (shapefile, GeoPackage, GeoJSON) of release areas in the DEM's
    /// coordinates, and the attribute that holds each area's thickness (m).
    std::string footprintFile;
    std::string thicknessAttribute = "thickness";
    /// polygon: the local frame's origin, subtracted from the file's coordinates as it is read;
    /// set by toLocalFrame (firn/gis.h), not a scene key.
    Vec3d footprintOrigin = {0.0, 0.0, 0.0};
    /// The name of an earlier weak-layer body this body lies above, across a slip surface
    /// (firn/slip_contact.h): its particles get the upper velocity field. Empty: one field.
    std::string slidesOn;
    /// Coulomb friction of the slip surface once the layer has collapsed; < 0: the layer's
    /// critical-state friction M_d / sqrt(3) (slipFrictionOfWeakLayer).
    double slipFriction = -1.0;
    SourceLoc loc;
};

/// A layer-like body: seeded on the terrain (or on another layer) with a normal thickness.
inline bool isLayerShape(BodyShape shape) {
    return shape == BodyShape::Layer || shape == BodyShape::Polygon;
}

/// [[cut]]: a saw cut, a region of a named layer body removed at t = 0.
struct CutDesc {
    std::string layer;   ///< name of a layer body
    double fromX = 0.0;  ///< m
    double length = 0.0; ///< m, along x
    Saw saw = Saw::QuasiStatic;
    SourceLoc loc;
};

/// [output]
struct OutputDesc {
    std::string directory; ///< default out/<name>
    bool particles = true;
    /// of density, velocity, failed, eta
    std::vector<std::string> volumes = {"density", "velocity"};
    /// Checkpoints (firn/checkpoint.h) at the end of every this many frames (0: not by frames)
    /// and whenever this many minutes of wall time have passed since the last (0: not by time).
    int checkpointEveryFrames = 0;
    double checkpointEveryMinutes = 10.0;
    /// Peak rasters (pft, pfv, ppr, dft; firn/peak_fields.h) on the DEM's grid, for scenes on a
    /// heightfield; rasterCell > 0 sets another cell size, m.
    bool rasters = true;
    double rasterCell = 0.0;
    /// The avalanche's path line (any OGR line file, in the DEM's coordinates; resolved against
    /// the scene's folder), for the runout and alpha along it; empty: derived from the flow.
    std::string path;
    double runoutPressure = 1.0; ///< kPa: the runout point ends the ppr >= this footprint
    SourceLoc loc;               ///< the [output] table, for errors about the path file
};

/// [render]: defaults for `firn render` (its command-line options override them).
struct RenderDesc {
    int width = 960;  ///< pixels
    int height = 540; ///< pixels
    ColorBy colorBy = ColorBy::Speed;
    /// Colour-map range; both NaN = automatic (0 to the largest value over the frames).
    std::array<double, 2> colorRange = {std::numeric_limits<double>::quiet_NaN(),
                                        std::numeric_limits<double>::quiet_NaN()};
    bool autoCamera = true;                 ///< false once camera_position and look_at are given
    Vec3d cameraPosition = {0.0, 0.0, 0.0}; ///< m
    Vec3d lookAt = {0.0, 0.0, 0.0};         ///< m
    double fovDeg = 40.0;                   ///< vertical field of view, degrees
    int contactFrames = 12;                 ///< frames on the contact sheet
};

struct SceneDesc {
    std::string path; ///< the scene file as given
    SimulationDesc simulation;
    GridDesc grid;
    std::vector<MaterialDesc> materials;
    std::vector<TerrainDesc> terrains;
    std::vector<BodyDesc> bodies;
    std::vector<CutDesc> cuts;
    OutputDesc output;
    RenderDesc render;
    std::string resolvedToml; ///< the scene as run, overrides applied, as TOML text
    /// The simulation's local frame: a scene coordinate is frameOrigin plus the simulated one.
    /// Zero unless toLocalFrame (firn/gis.h) moved a scene on a far-off DEM next to 0.
    Vec3d frameOrigin = {0.0, 0.0, 0.0};
};

/// Parses and validates a scene file. `overrides` are "key.path=value" strings (from --set)
/// whose value is parsed as a TOML value ("grid.dx=0.025", "simulation.name=\"a\"", a bare
/// word is taken as a string). Throws SceneError naming file, line and key.
SceneDesc loadScene(const std::string& path, const std::vector<std::string>& overrides = {});

/// Same, from text in memory; `path` is used in messages and to resolve relative files.
SceneDesc parseScene(const std::string& text, const std::string& path,
                     const std::vector<std::string>& overrides = {});

const char* toString(Transfer);
const char* toString(MaterialModel);
const char* toString(ColorBy);
/// Reads a colour-by word ("density", "speed", "failed", "eta"); false if it is none of them.
bool parseColorBy(const std::string& word, ColorBy& out);

} // namespace firn
