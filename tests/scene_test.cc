// Scene parsing: every field of a full 2D and 3D scene, then one test per class of error with
// its exact message, line and column included (as Mitsuba's parser tests do).
#include <firn/scene.h>
#include <firn/snow_parameters.h>

#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>

using namespace firn;

namespace {

const char* const kPath = "scenes/test.toml";

// The message parseScene throws for `text`, or "no error".
std::string errorOf(const std::string& text, const std::vector<std::string>& overrides = {}) {
    try {
        parseScene(text, kPath, overrides);
    } catch (const SceneError& e) {
        return e.what();
    }
    return "no error";
}

// A small valid 3D scene that error tests append to or override.
const std::string kMinimal = R"([simulation]
name = "mini"

[grid]
dx = 0.1

[[material]]
name = "slab"
model = "snow"

[[body]]
material = "slab"
shape = "box"
min = [0, 0, 0]
max = [1, 1, 1]
)";

const std::string kFull3d = R"(# every key of the format
[simulation]
name = "full"
dimension = 3
end_time = 2.5
frame_rate = 30
gravity = [0.5, -9.0, 0.25]
seed = 42

[grid]
dx = 0.04
particles_per_cell = 27
transfer = "flip"
flip_blend = 0.9
cfl = 0.5
max_dt = 2e-4
jitter = 0.25

[[material]]
name = "slab"
model = "snow"
density = 300
youngs_modulus = 2.0e6
poisson_ratio = 0.25
critical_state_slope = 1.1
cohesion_ratio = 0.4
initial_p0 = 3.0e4
hardening = 6

[[material]]
name = "weak"
model = "weak_layer"
density = 150
softening = 0.5
dynamic_critical_state_slope = 0.9

[[material]]
name = "sand"
model = "granular"
friction_angle = 35

[[material]]
name = "block"
model = "elastic"
youngs_modulus = 5e7

[[terrain]]
shape = "plane"
point = [0, 1, 0]
normal = [0, 3, 4]
boundary = "slip"

[[terrain]]
shape = "profile"
points = [[0.0, 13.0], [10, 5.0], [25.0, 0.0]]
friction = 0.6

[[terrain]]
shape = "heightfield"
file = "dem.asc"
boundary = "sticky"

[[body]]
name = "base"
material = "weak"
shape = "layer"
thickness = 0.1
x_range = [0, 20]
z_range = [-2, 2]

[[body]]
material = "slab"
shape = "layer"
on_top_of = "base"
thickness = 0.5
x_range = [1, 19]
z_range = [-1, 1]
thickness_noise = { std = 0.1, correlation_length = 5 }

[[body]]
material = "block"
shape = "box"
min = [0, 0, 0]
max = [1, 0.5, 1]
velocity = [1, 0, -1]

[[body]]
material = "sand"
shape = "sphere"
center = [2, 3, 4]
radius = 0.5

[[cut]]
layer = "base"
from_x = 4.5
length = 0.3

[output]
directory = "out/custom"
particles = false
volumes = ["density", "failed"]
)";

// A folder holding the heightfield that kFull3d names, relative to the scene.
std::string sceneFolderWithDem() {
    const auto folder = std::filesystem::temp_directory_path() / "firn_scene_test";
    std::filesystem::create_directories(folder);
    std::ofstream(folder / "dem.asc") << "ncols 2\nnrows 2\n";
    return folder.string();
}

void checkVec(const Vec3d& actual, const Vec3d& expected) {
    for (int i = 0; i < 3; ++i) CHECK(actual[i] == Approx(expected[i]));
}

} // namespace

TEST_CASE("A full 3D scene fills every field", "[scene]") {
    const std::string folder = sceneFolderWithDem();
    const SceneDesc scene = parseScene(kFull3d, folder + "/test.toml");

    CHECK(scene.path == folder + "/test.toml");
    CHECK(scene.simulation.name == "full");
    CHECK(scene.simulation.dimension == 3);
    CHECK(scene.simulation.endTime == 2.5);
    CHECK(scene.simulation.frameRate == 30.0);
    checkVec(scene.simulation.gravity, {0.5, -9.0, 0.25});
    CHECK(scene.simulation.seed == 42u);

    CHECK(scene.grid.dx == 0.04);
    CHECK(scene.grid.particlesPerCell == 27);
    CHECK(scene.grid.transfer == Transfer::Flip);
    CHECK(scene.grid.flipBlend == 0.9);
    CHECK(scene.grid.cfl == 0.5);
    CHECK(scene.grid.maxDt == 2e-4);
    CHECK(scene.grid.jitter == 0.25);

    REQUIRE(scene.materials.size() == 4);
    const MaterialDesc& slab = scene.materials[0];
    CHECK(slab.name == "slab");
    CHECK(slab.model == MaterialModel::Snow);
    CHECK(slab.density == 300.0);
    CHECK(slab.youngsModulus == 2.0e6);
    CHECK(slab.poissonRatio == 0.25);
    CHECK(slab.criticalStateSlope == 1.1);
    CHECK(slab.cohesionRatio == 0.4);
    CHECK(slab.initialP0 == 3.0e4);
    CHECK(slab.hardening == 6.0);
    CHECK(slab.loc.file == folder + "/test.toml");
    CHECK(slab.loc.line == 19);
    CHECK(slab.loc.column == 1);
    const MaterialDesc& weak = scene.materials[1];
    CHECK(weak.model == MaterialModel::WeakLayer);
    CHECK(weak.density == 150.0);
    CHECK(weak.youngsModulus == weakLayerTable(150.0).youngsModulus.value); // from the table
    CHECK(weak.softening == 0.5);
    CHECK(weak.dynamicCriticalStateSlope == 0.9);
    CHECK(weak.criticalStateSlope == 0.85); // from the table
    CHECK(scene.materials[2].model == MaterialModel::Granular);
    CHECK(scene.materials[2].frictionAngle == 35.0);
    CHECK(scene.materials[3].model == MaterialModel::Elastic);
    CHECK(scene.materials[3].youngsModulus == 5e7);
    CHECK(scene.materials[3].poissonRatio == 0.3); // default

    REQUIRE(scene.terrains.size() == 3);
    const TerrainDesc& plane = scene.terrains[0];
    CHECK(plane.shape == TerrainShape::Plane);
    checkVec(plane.point, {0, 1, 0});
    checkVec(plane.normal, {0, 0.6, 0.8}); // normalised on read
    CHECK(plane.boundary == Boundary::Slip);
    CHECK(plane.loc.line == 47);
    const TerrainDesc& profile = scene.terrains[1];
    CHECK(profile.shape == TerrainShape::Profile);
    REQUIRE(profile.points.size() == 3);
    CHECK(profile.points[1][0] == 10.0);
    CHECK(profile.points[1][1] == 5.0);
    CHECK(profile.points[2][0] == 25.0);
    CHECK(profile.boundary == Boundary::Friction);
    CHECK(profile.friction == 0.6);
    const TerrainDesc& dem = scene.terrains[2];
    CHECK(dem.shape == TerrainShape::Heightfield);
    CHECK(dem.file == (std::filesystem::path(folder) / "dem.asc").string());
    CHECK(dem.boundary == Boundary::Sticky);

    REQUIRE(scene.bodies.size() == 4);
    const BodyDesc& base = scene.bodies[0];
    CHECK(base.name == "base");
    CHECK(base.material == "weak");
    CHECK(base.materialIndex == 1);
    CHECK(base.shape == BodyShape::Layer);
    CHECK(base.onTopOf == "ground");
    CHECK(base.thickness == 0.1);
    CHECK(base.xRange == std::array<double, 2>{0, 20});
    CHECK(base.zRange == std::array<double, 2>{-2, 2});
    CHECK(base.thicknessNoise.std == 0.0);
    const BodyDesc& top = scene.bodies[1];
    CHECK(top.name.empty());
    CHECK(top.materialIndex == 0);
    CHECK(top.onTopOf == "base");
    CHECK(top.thickness == 0.5);
    CHECK(top.thicknessNoise.std == 0.1);
    CHECK(top.thicknessNoise.correlationLength == 5.0);
    const BodyDesc& box = scene.bodies[2];
    CHECK(box.shape == BodyShape::Box);
    CHECK(box.materialIndex == 3);
    checkVec(box.min, {0, 0, 0});
    checkVec(box.max, {1, 0.5, 1});
    checkVec(box.velocity, {1, 0, -1});
    const BodyDesc& sphere = scene.bodies[3];
    CHECK(sphere.shape == BodyShape::Sphere);
    CHECK(sphere.materialIndex == 2);
    checkVec(sphere.center, {2, 3, 4});
    CHECK(sphere.radius == 0.5);
    CHECK(sphere.loc.line == 87);

    REQUIRE(scene.cuts.size() == 1);
    CHECK(scene.cuts[0].layer == "base");
    CHECK(scene.cuts[0].fromX == 4.5);
    CHECK(scene.cuts[0].length == 0.3);

    CHECK(scene.output.directory == "out/custom");
    CHECK_FALSE(scene.output.particles);
    CHECK(scene.output.volumes == std::vector<std::string>{"density", "failed"});

    // The resolved text reads back as the same scene.
    const SceneDesc again = parseScene(scene.resolvedToml, folder + "/again.toml");
    CHECK(again.grid.dx == 0.04);
    CHECK(again.bodies.size() == 4);
}

TEST_CASE("A 2D scene takes two-component vectors and defaults", "[scene]") {
    const SceneDesc scene = parseScene(R"([simulation]
name = "flat"
dimension = 2

[[material]]
name = "slab"
model = "snow"

[[terrain]]
shape = "plane"
point = [0, 0]
normal = [0, 2]

[[body]]
material = "slab"
shape = "box"
min = [0, 0]
max = [2, 1]
velocity = [3, 0]

[[body]]
name = "layer"
material = "slab"
shape = "layer"
thickness = 0.2
x_range = [0, 5]
)",
                                       kPath);
    CHECK(scene.simulation.dimension == 2);
    checkVec(scene.simulation.gravity, {0, -9.81, 0});
    CHECK(scene.simulation.endTime == 1.0);
    CHECK(scene.simulation.seed == 1u);
    CHECK(scene.grid.dx == 0.05);
    CHECK(scene.grid.particlesPerCell == 8);
    CHECK(scene.grid.transfer == Transfer::Apic);
    checkVec(scene.terrains[0].normal, {0, 1, 0});
    CHECK(scene.terrains[0].friction == 0.4);
    checkVec(scene.bodies[0].min, {0, 0, 0});
    checkVec(scene.bodies[0].max, {2, 1, 0});
    checkVec(scene.bodies[0].velocity, {3, 0, 0});
    CHECK(scene.bodies[1].xRange == std::array<double, 2>{0, 5});
    CHECK(scene.output.directory == "out/flat");
    CHECK(scene.output.particles);
    CHECK(scene.output.volumes == std::vector<std::string>{"density", "velocity"});
}

TEST_CASE("Enumerations print as the scene spells them", "[scene]") {
    CHECK(std::string(toString(Transfer::Apic)) == "apic");
    CHECK(std::string(toString(Transfer::Flip)) == "flip");
    CHECK(std::string(toString(Transfer::Xpic)) == "xpic");
    CHECK(std::string(toString(MaterialModel::WeakLayer)) == "weak_layer");
    CHECK(std::string(toString(MaterialModel::Granular)) == "granular");
}

TEST_CASE("A TOML syntax error names its line, column and key, and shows the line",
          "[scene][errors]") {
    // As compilers print it: the line, then a caret under the column.
    CHECK(errorOf("[grid]\ndx = = 0.1\n") ==
          "scenes/test.toml:2:6: error: grid.dx: syntax error: Error while parsing value: could "
          "not determine value type\n"
          " 2 | dx = = 0.1\n"
          "   |      ^");
    CHECK(errorOf("[grid]\ndx = 0.1 0.2\n") ==
          "scenes/test.toml:2:10: error: grid.dx: syntax error: Error while parsing key-value "
          "pair: expected a comment or whitespace, saw '0'\n"
          " 2 | dx = 0.1 0.2\n"
          "   |          ^");
    // An entry of an array of tables is named as validation names it: by name once known.
    const std::string bodies = kMinimal + "\n[[body]]\nname = \"ball\"\nradius = 0..5\n";
    CHECK(errorOf(bodies).find("error: body \"ball\": radius: syntax error: ") !=
          std::string::npos);
    CHECK(errorOf(kMinimal + "\n[[body]]\nradius = 0..5\n")
              .find("error: body 2: radius: syntax error: ") != std::string::npos);
    // A broken table header names the table; tabs stay tabs under the caret.
    CHECK(errorOf("[grid\ndx = 0.1\n").find("scenes/test.toml:1:6: error: grid: syntax error: ") ==
          0);
    CHECK(errorOf("[grid]\n\tdx = = 1\n").find("\n 2 | \tdx = = 1\n   | \t     ^") !=
          std::string::npos);
}

TEST_CASE("A scene may not ask for more frames than a run can write", "[scene][errors]") {
    CHECK(errorOf(kMinimal, {"simulation.end_time=1e4", "simulation.frame_rate=1e5"}) ==
          "--set: error: simulation.frame_rate: end_time x frame_rate = 1000000000 frames; at "
          "most 1000000 (lower frame_rate or end_time)");
    CHECK(errorOf(kMinimal, {"simulation.end_time=1e6"}) ==
          "--set: error: simulation.end_time: end_time x frame_rate = 24000000 frames; at most "
          "1000000 (lower frame_rate or end_time)");
    CHECK(errorOf(kMinimal, {"simulation.end_time=1e4"}) == "no error");
}

TEST_CASE("An unknown key is an error, with a suggestion", "[scene][errors]") {
    CHECK(errorOf(kMinimal + "\n[output]\nparticles = true\nvolume = []\n") ==
          "scenes/test.toml:19:1: error: output.volume: unknown key; did you mean 'volumes'?");
    CHECK(errorOf("[grid]\ndx = 0.1\ndxx = 0.2\n") ==
          "scenes/test.toml:3:1: error: grid.dxx: unknown key; did you mean 'dx'?");
}

TEST_CASE("An unknown table is an error", "[scene][errors]") {
    CHECK(errorOf(kMinimal + "\n[gird]\ndx = 0.1\n") ==
          "scenes/test.toml:17:2: error: gird: unknown table; did you mean 'grid'?");
}

TEST_CASE("A value of the wrong type is an error", "[scene][errors]") {
    CHECK(errorOf("[grid]\ndx = \"fine\"\n") ==
          "scenes/test.toml:2:6: error: grid.dx: must be a number, got string");
    CHECK(errorOf("[grid]\nparticles_per_cell = 8.0\n") ==
          "scenes/test.toml:2:22: error: grid.particles_per_cell: must be an integer, got float");
}

TEST_CASE("An out-of-range value is an error", "[scene][errors]") {
    const std::string text = R"([simulation]
name = "pst"

[[material]]
name = "slab"
model = "snow"
poisson_ratio = 0.7
)";
    CHECK(errorOf(text) == "scenes/test.toml:7:17: error: material \"slab\": poisson_ratio: "
                           "must be in [0, 0.5), got 0.7");
    CHECK(errorOf("[grid]\ncfl = 0\n") ==
          "scenes/test.toml:2:7: error: grid.cfl: must be in (0, 10], got 0");
    CHECK(errorOf("[output]\nvolumes = [\"density\", \"speed\"]\n") ==
          "scenes/test.toml:2:23: error: output.volumes: entries must be one of \"density\", "
          "\"velocity\", \"failed\", \"eta\", got \"speed\"");
    CHECK(errorOf("[grid]\ntransfer = \"mls\"\n") ==
          "scenes/test.toml:2:12: error: grid.transfer: must be one of \"apic\", \"pic\", "
          "\"flip\", \"xpic\", got \"mls\"");
}

TEST_CASE("A missing required key is reported at its table header", "[scene][errors]") {
    CHECK(errorOf("[[material]]\nname = \"slab\"\n") ==
          "scenes/test.toml:1:1: error: material \"slab\": model: missing required key");
    CHECK(errorOf(kMinimal + "\n[[body]]\nmaterial = \"slab\"\nshape = \"sphere\"\nradius = 1\n") ==
          "scenes/test.toml:17:1: error: body 2: center: missing required key for shape "
          "\"sphere\"");
}

TEST_CASE("A body naming an undefined material is an error", "[scene][errors]") {
    const std::string text = kMinimal + R"(
[[material]]
name = "weak"
model = "weak_layer"

[[body]]
material = "slabb"
shape = "sphere"
)";
    CHECK(errorOf(text) == "scenes/test.toml:22:12: error: body 2: material \"slabb\" is not "
                           "defined (materials: slab, weak)");
}

TEST_CASE("A heightfield file must exist next to the scene", "[scene][errors]") {
    CHECK(errorOf(kMinimal + "\n[[terrain]]\nshape = \"heightfield\"\nfile = \"missing.asc\"\n") ==
          "scenes/test.toml:19:8: error: terrain 1: file: file not found: scenes/missing.asc");
}

TEST_CASE("An override naming an unknown key or table is an error", "[scene][errors]") {
    CHECK(errorOf(kMinimal, {"grid.dxx=0.2"}) ==
          "--set: error: grid.dxx: unknown key; did you mean 'dx'?");
    CHECK(errorOf(kMinimal, {"solver.dx=0.2"}) == "--set: error: solver: unknown table");
    CHECK(errorOf(kMinimal, {"material.slabb.density=100"}) ==
          "--set: error: material.slabb.density: no [[material]] named \"slabb\" (named: slab)");
    CHECK(errorOf(kMinimal, {"dx=0.2"}) ==
          "--set: error: dx: expected <table>.<key>=<value>, <material|body>.<name>.<key>=<value> "
          "or cut.<layer>.<key>=<value>");
    CHECK(errorOf(kMinimal, {"grid.dx=-1"}) == "--set: error: grid.dx: must be > 0, got -1");
}

TEST_CASE("Overrides apply before validation and show in the resolved TOML", "[scene]") {
    const SceneDesc scene =
        parseScene(kMinimal, kPath,
                   {"grid.dx=0.025", "grid.transfer=pic", "material.slab.density=180",
                    "output.volumes=[\"failed\"]", "simulation.name = \"other\""});
    CHECK(scene.grid.dx == 0.025);
    CHECK(scene.grid.transfer == Transfer::Pic);
    CHECK(scene.materials[0].density == 180.0);
    CHECK(scene.output.volumes == std::vector<std::string>{"failed"});
    CHECK(scene.output.directory == "out/other");
    CHECK(scene.resolvedToml.find("dx = 0.025") != std::string::npos);
    CHECK(scene.resolvedToml.find("transfer = \"pic\"") != std::string::npos);
    CHECK(parseScene(scene.resolvedToml, kPath).grid.dx == 0.025);
}

TEST_CASE("A 2D scene rejects a vector with three components", "[scene][errors]") {
    const std::string text = R"([simulation]
dimension = 2
gravity = [0, -9.81, 0]
)";
    CHECK(errorOf(text) == "scenes/test.toml:3:11: error: simulation.gravity: must have 2 "
                           "components in a 2D scene, got 3");
}

TEST_CASE("A key of another model or shape is an error", "[scene][errors]") {
    CHECK(errorOf(kMinimal + "friction_angle = 30\n") ==
          "scenes/test.toml:16:1: error: body 1: friction_angle: unknown key");
    const std::string text = R"([[material]]
name = "slab"
model = "snow"
friction_angle = 30
)";
    CHECK(errorOf(text) == "scenes/test.toml:4:1: error: material \"slab\": friction_angle: "
                           "does not apply to model \"snow\"");
    CHECK(errorOf(kMinimal + "radius = 2\n") ==
          "scenes/test.toml:16:1: error: body 1: radius: does not apply to shape \"box\"");
}

TEST_CASE("mu(I) friction: its keys, its default and its errors", "[scene][errors]") {
    const std::string sand = R"([[material]]
name = "sand"
model = "granular"
friction_angle = 30
)";
    // Without dynamic_friction_angle the friction is friction_angle at every rate.
    const SceneDesc still = parseScene(sand, kPath);
    CHECK(still.materials[0].dynamicFrictionAngle == 30.0);
    CHECK(still.materials[0].origins.at("dynamic_friction_angle") ==
          "default: friction_angle (rate-independent)");
    const SceneDesc rated = parseScene(
        sand + "dynamic_friction_angle = 40\ngrain_diameter = 0.002\ninertial_number_scale = 0.3\n",
        kPath);
    CHECK(rated.materials[0].dynamicFrictionAngle == 40.0);
    CHECK(rated.materials[0].grainDiameter == 0.002);
    CHECK(rated.materials[0].inertialNumberScale == 0.3);
    CHECK(errorOf(sand + "dynamic_friction_angle = 25\n") ==
          "scenes/test.toml:5:26: error: material \"sand\": dynamic_friction_angle: must not be "
          "below friction_angle (30 degrees): mu(I) friction rises with the shear rate");
    CHECK(errorOf(sand + "grain_diameter = 0.002\n") ==
          "scenes/test.toml:5:18: error: material \"sand\": grain_diameter: has no effect without "
          "dynamic_friction_angle (the mu(I) friction at large inertial number)");
    CHECK(errorOf(sand + "inertial_number_scale = 0.3\n") ==
          "scenes/test.toml:5:25: error: material \"sand\": inertial_number_scale: has no effect "
          "without dynamic_friction_angle (the mu(I) friction at large inertial number)");
}

TEST_CASE("loadScene reads a file and names one it cannot open", "[scene]") {
    const std::string folder = sceneFolderWithDem();
    const std::string path = folder + "/load.toml";
    std::ofstream(path) << kMinimal;
    const SceneDesc scene = loadScene(path, {"simulation.seed=7"});
    CHECK(scene.path == path);
    CHECK(scene.simulation.seed == 7u);
    CHECK_THROWS_WITH(loadScene(folder + "/absent.toml"),
                      folder + "/absent.toml: error: cannot open scene file");
}

TEST_CASE("[render] sets the review renderer's defaults", "[scene]") {
    const SceneDesc d = parseScene(kMinimal + R"(
[render]
width = 1280
height = 720
color_by = "eta"
color_range = [0.0, 0.2]
camera_position = [10.0, 5.0, 20.0]
look_at = [10.0, 0.0, 0.0]
fov_deg = 30.0
contact_frames = 6
)",
                                   kPath);
    CHECK(d.render.width == 1280);
    CHECK(d.render.height == 720);
    CHECK(d.render.colorBy == ColorBy::Eta);
    CHECK(d.render.colorRange[1] == 0.2);
    CHECK_FALSE(d.render.autoCamera);
    CHECK(d.render.cameraPosition[2] == 20.0);
    CHECK(d.render.lookAt[0] == 10.0);
    CHECK(d.render.fovDeg == 30.0);
    CHECK(d.render.contactFrames == 6);
    const SceneDesc plain = parseScene(kMinimal, kPath);
    CHECK(plain.render.autoCamera);
    CHECK(plain.render.colorBy == ColorBy::Speed);
    CHECK(std::isnan(plain.render.colorRange[0]));
}

TEST_CASE("[render] errors name the key", "[scene][errors]") {
    CHECK(errorOf(kMinimal + "\n[render]\ncamera_position = [1.0, 2.0, 3.0]\n")
              .find("render.look_at: missing required key for a positioned camera") !=
          std::string::npos);
    CHECK(errorOf(kMinimal + "\n[render]\ncolor_by = \"velocity\"\n")
              .find("render.color_by: must be one of \"density\", \"speed\", \"failed\", "
                    "\"eta\", got \"velocity\"") != std::string::npos);
    CHECK(errorOf(kMinimal, {"render.width=3"}).find("render.width") != std::string::npos);
}

TEST_CASE("Settling is on by default, off with a gravity ramp, and not both", "[scene][errors]") {
    CHECK(parseScene("[simulation]\nname = \"a\"\n", kPath).simulation.settle);
    const SceneDesc ramped = parseScene("[simulation]\ngravity_ramp = 0.1\n", kPath);
    CHECK_FALSE(ramped.simulation.settle);
    CHECK(ramped.simulation.gravityRamp == 0.1);
    CHECK_FALSE(parseScene("[simulation]\nsettle = false\n", kPath).simulation.settle);
    CHECK(errorOf("[simulation]\ngravity_ramp = 0.1\nsettle = true\n") ==
          "scenes/test.toml:3:10: error: simulation.settle: settle = true and gravity_ramp > 0 "
          "are two ways to start a scene at rest; give one of them");
    CHECK(errorOf("[simulation]\nsettle_max_time = 0.0\n") ==
          "scenes/test.toml:2:19: error: simulation.settle_max_time: must be > 0, got 0");
}

TEST_CASE("The FLIP fraction is a blend or a relaxation time, not both", "[scene][errors]") {
    const std::string both = "[grid]\nflip_blend = 0.99\nflip_relaxation_time = 0.5\n";
    CHECK(errorOf(both) == "scenes/test.toml:3:24: error: grid.flip_relaxation_time: flip_blend "
                           "and flip_relaxation_time are two ways to set the FLIP fraction: give "
                           "one");
    // From the command line, one overrides the other given in the file.
    const SceneDesc relaxed =
        parseScene("[grid]\nflip_blend = 1.0\n", kPath, {"grid.flip_relaxation_time=0.5"});
    CHECK(relaxed.grid.flipRelaxationTime == 0.5);
    CHECK(parseScene(relaxed.resolvedToml, kPath).grid.flipRelaxationTime == 0.5);
    const SceneDesc blended =
        parseScene("[grid]\nflip_relaxation_time = 0.5\n", kPath, {"grid.flip_blend=0.99"});
    CHECK(blended.grid.flipRelaxationTime == 0.0);
    CHECK(blended.grid.flipBlend == 0.99);
    CHECK(parseScene(blended.resolvedToml, kPath).grid.flipBlend == 0.99);
    CHECK(errorOf("[grid]\nflip_relaxation_time = 0.0\n") ==
          "scenes/test.toml:2:24: error: grid.flip_relaxation_time: must be > 0, got 0");
}

TEST_CASE("A saw cut must leave part of its layer", "[scene][errors]") {
    const std::string layer =
        kMinimal + "\n[[body]]\nname = \"weak\"\nmaterial = \"slab\"\nshape = \"layer\"\n"
                   "thickness = 0.1\nx_range = [0, 6]\nz_range = [0, 1]\n"
                   "\n[[cut]]\nlayer = \"weak\"\nfrom_x = 5.4\nlength = 0.6\n";
    CHECK(errorOf(layer) == "no error");
    CHECK(errorOf(layer, {"cut.weak.length=6"}) ==
          "--set: error: cut 1: length: 6 m is not shorter than layer \"weak\" (x_range [0, 6]): "
          "the cut would leave nothing of it");
    CHECK(errorOf(layer, {"cut.weak.from_x=6"}) ==
          "--set: error: cut 1: from_x: the cut [6, 6.6] misses layer \"weak\" (x_range [0, 6])");
    CHECK(errorOf(layer, {"cut.weak.from_x=-1"}) == "--set: error: cut 1: from_x: the cut [-1, "
                                                    "-0.4] misses layer \"weak\" (x_range [0, 6])");
    // Hanging over an end is a cut at that end, as PST scenes may write it.
    CHECK(errorOf(layer, {"cut.weak.from_x=5.7"}) == "no error");
}

TEST_CASE("A saw cut is quasi-static unless it says instant", "[scene]") {
    const std::string layer =
        kMinimal + "\n[[body]]\nname = \"weak\"\nmaterial = \"slab\"\nshape = \"layer\"\n"
                   "thickness = 0.1\nx_range = [0, 6]\nz_range = [0, 1]\n"
                   "\n[[cut]]\nlayer = \"weak\"\nfrom_x = 5.4\nlength = 0.6\n";
    CHECK(parseScene(layer, kPath).cuts.at(0).saw == Saw::QuasiStatic);
    const SceneDesc instant = parseScene(layer, kPath, {"cut.weak.saw=\"instant\""});
    CHECK(instant.cuts.at(0).saw == Saw::Instant);
    CHECK(parseScene(instant.resolvedToml, kPath).cuts.at(0).saw == Saw::Instant);
    CHECK(errorOf(layer, {"cut.weak.saw=\"fast\""}) ==
          "--set: error: cut 1: saw: must be one of \"quasi_static\", \"instant\", got \"fast\"");
}

TEST_CASE("A layer's thickness is a number or a profile along x, not both", "[scene][errors]") {
    const std::string layer =
        kMinimal + "\n[[body]]\nname = \"slab2\"\nmaterial = \"slab\"\nshape = \"layer\"\n"
                   "x_range = [0, 20]\nz_range = [0, 1]\n"
                   "thickness_profile = [[0.0, 0.3], [10.0, 0.5], [20.0, 0.3]]\n";
    const SceneDesc scene = parseScene(layer, kPath);
    const BodyDesc& body = scene.bodies.back();
    REQUIRE(body.thicknessProfile.size() == 3);
    CHECK(body.thicknessProfile[1][0] == 10.0);
    CHECK(body.thicknessProfile[1][1] == 0.5);
    CHECK(body.thickness == 0.5); // the largest, which bounds the layer's seeding box
    CHECK(parseScene(scene.resolvedToml, kPath).bodies.back().thicknessProfile ==
          body.thicknessProfile);
    CHECK(errorOf(layer, {"body.slab2.thickness=0.4"}) ==
          "scenes/test.toml:23:21: error: body \"slab2\": thickness_profile: give thickness or "
          "thickness_profile, not both");
    CHECK(errorOf(layer, {"body.slab2.thickness_profile=[[0.0, 0.3], [5.0, 0.0]]"}) ==
          "--set: error: body \"slab2\": thickness_profile: point 2 thickness must be > 0, got 0");
    CHECK(errorOf(layer, {"body.slab2.thickness_profile=[[0.0, 0.3], [5.0]]"}) ==
          "--set: error: body \"slab2\": thickness_profile: point 2 must be an array [x, "
          "thickness]");
    CHECK(errorOf(layer, {"body.slab2.thickness_profile=[[5.0, 0.3], [5.0, 0.4]]"}) ==
          "--set: error: body \"slab2\": thickness_profile: x must increase strictly, got [5, "
          "0.3] then [5, 0.4]");
    std::string bare = layer;
    bare.erase(bare.find("thickness_profile"));
    CHECK(errorOf(bare) == "scenes/test.toml:17:1: error: body \"slab2\": thickness: missing "
                           "required key for shape \"layer\" (or thickness_profile)");
}

TEST_CASE("The as-run TOML reads back as the same scene (fuzzing found two ways it did not)",
          "[scene]") {
    // A --set value that is not UTF-8 would be written altered into scene.toml.
    CHECK(errorOf(kMinimal, {"simulation.name=a\xC8"
                             "b"}) == "--set: error: not valid UTF-8 text");
    // toml++ 3.3 wrote a string starting with a newline as a multi-line one, whose first
    // newline TOML drops on reading.
    const SceneDesc scene = parseScene(kMinimal, kPath, {"simulation.name=\"\\nly\""});
    CHECK(scene.simulation.name == "\nly");
    const SceneDesc again = parseScene(scene.resolvedToml, kPath);
    CHECK(again.simulation.name == "\nly");
    CHECK(again.resolvedToml == scene.resolvedToml);
}

TEST_CASE("XPIC's order is an integer from 1 to 16, 2 by default", "[scene][errors]") {
    CHECK(parseScene("[grid]\ntransfer = \"xpic\"\n", kPath).grid.xpicOrder == 2);
    const SceneDesc fourth = parseScene("[grid]\ntransfer = \"xpic\"\nxpic_order = 4\n", kPath);
    CHECK(fourth.grid.transfer == Transfer::Xpic);
    CHECK(fourth.grid.xpicOrder == 4);
    CHECK(errorOf("[grid]\nxpic_order = 0\n") ==
          "scenes/test.toml:2:14: error: grid.xpic_order: must be in [1, 16], got 0");
}

TEST_CASE("boundary = \"samosat\" takes AvaFrame's mu 0.155 when the scene gives none",
          "[scene][samosat]") {
    const std::string terrain =
        "\n[[terrain]]\nshape = \"plane\"\npoint = [0, 0, 0]\nnormal = [0, 1, 0]\n"
        "boundary = \"samosat\"\n";
    const SceneDesc scene = parseScene(kMinimal + terrain + "samosat_tau0 = 500.0\n", kPath);
    CHECK(scene.terrains[0].friction == 0.155);
    CHECK(scene.terrains[0].samosatTau0 == 500.0);
    CHECK(scene.terrains[0].samosatKappa == 0.43);
    CHECK(scene.terrains[0].samosatB == 4.13);
    const std::string error = errorOf(kMinimal + terrain + "samosat_tau0 = -1.0\n");
    CHECK_THAT(error, Catch::Contains("samosat_tau0") && Catch::Contains(">= 0"));
}

TEST_CASE("output.path needs a DEM and an existing file, and runout_pressure is positive",
          "[scene][path]") {
    CHECK_THAT(errorOf(kMinimal + "\n[output]\npath = \"path.geojson\"\n"),
               Catch::Contains("18:8: error: output.path") && Catch::Contains("no heightfield"));
    CHECK_THAT(errorOf(kMinimal + "\n[output]\nrunout_pressure = 0.0\n"),
               Catch::Contains("runout_pressure"));
    CHECK(
        parseScene(kMinimal + "\n[output]\nrunout_pressure = 3.0\n", kPath).output.runoutPressure ==
        3.0);
}
