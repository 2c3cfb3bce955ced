// The firn command line end to end: the real binary is spawned with its stdout and stderr in
// files, and the tests check exit codes (0 ok, 1 scene/usage, 2 unstable, 3 I/O, 130
// interrupted), the exact error messages, the help texts, `firn check`, and what a run leaves in
// its output folder after finishing, blowing up, being interrupted or failing to write.
#include "firn_process.h"

#include <firn_test_paths.h>

#include <catch2/catch.hpp>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace fs = std::filesystem;
using namespace firn::test;

namespace {

const std::string& kTiny = firn::test::kTinyScene;

// A 3D scene on a heightfield file that does not exist (heightfields are 3D only).
const std::string kMissingDem = R"([simulation]
name = "dem"
dimension = 3

[[material]]
name = "snow"
model = "snow"

[[terrain]]
shape = "heightfield"
file = "missing.asc"

[[body]]
material = "snow"
shape = "box"
min = [0, 0, 0]
max = [1, 1, 1]
)";

// A stiff, light elastic block (P-wave speed ~1160 m/s) falling onto a plane with a CFL number
// of 8 and a large max_dt: the explicit elastic time-step limit is violated and the run blows up.
const std::string kUnstable = R"([simulation]
name = "unstable"
dimension = 2
end_time = 0.5
frame_rate = 30

[grid]
dx = 0.1
particles_per_cell = 4
cfl = 8.0
max_dt = 0.01

[[material]]
name = "block"
model = "elastic"
density = 100.0
youngs_modulus = 1.0e8

[[terrain]]
shape = "plane"
point = [0.0, 0.0]
normal = [0.0, 1.0]

[[body]]
material = "block"
shape = "box"
min = [0.0, 0.5]
max = [1.0, 1.0]
)";

// The core columns and keys of outputs.md, as it spells them.
const char* const kCoreColumns =
    "frame,time,steps,dt,particles,active_voxels,mass,com_x,com_y,com_z,momentum_x,momentum_y,"
    "momentum_z,kinetic_energy,max_speed,front_x,crack_tip_x,crack_speed,failed_fraction,"
    "wall_seconds";
const char* const kCoreSummaryKeys =
    "scene,dimension,particles,steps,frames,end_time,wall_seconds,threads,"
    "particle_steps_per_second,peak_rss_bytes,bytes_per_particle,mass_initial,mass_final,"
    "max_speed,max_crack_speed,mean_crack_speed,runout_x,alpha_angle_deg,status";

// `text` with its 1-based line `line` replaced by `replacement`.
std::string withLine(const std::string& text, int line, const std::string& replacement) {
    std::istringstream in(text);
    std::string out, l;
    for (int n = 1; std::getline(in, l); ++n) out += (n == line ? replacement : l) + "\n";
    return out;
}

std::vector<std::string> split(const std::string& text, char sep) {
    std::vector<std::string> parts;
    std::string part;
    std::istringstream in(text);
    while (std::getline(in, part, sep)) parts.push_back(part);
    if (!text.empty() && text.back() == sep && sep == ',') parts.push_back("");
    return parts;
}

/// Every file under `dir`, as paths relative to it.
std::set<std::string> filesUnder(const std::string& dir) {
    std::set<std::string> files;
    for (const auto& e : fs::recursive_directory_iterator(dir))
        if (!e.is_directory()) files.insert(fs::relative(e.path(), dir).string());
    return files;
}

/// Files whose name marks them as unfinished writes (".name.tmp" and the like).
std::vector<std::string> temporaryFiles(const std::string& dir) {
    std::vector<std::string> temps;
    for (const auto& e : fs::recursive_directory_iterator(dir)) {
        const std::string name = e.path().filename().string();
        if (name[0] == '.' || name.find(".tmp") != std::string::npos ||
            name.find('~') != std::string::npos)
            temps.push_back(name);
    }
    return temps;
}

std::string frameName(const std::string& kind, int k) {
    char name[64];
    std::snprintf(name, sizeof name, "frames/%s.%04d.vdb", kind.c_str(), k);
    return name;
}

// OpenVDB files start with the magic number 0x56444220 ("VDB " as a little-endian int32).
bool isVdbFile(const std::string& path) {
    return slurp(path).compare(0, 4, std::string(" BDV")) == 0;
}

// The raw text of `"key": value` in the summary, or "" when the key is absent.
std::string jsonValue(const std::string& json, const std::string& key) {
    std::smatch m;
    const std::regex re("\"" + key + "\"\\s*:\\s*(\"[^\"]*\"|[^,\\n}]+)");
    return std::regex_search(json, m, re) ? m[1].str() : "";
}

/// Checks metrics.csv: the core columns in the header, then exactly `frames` complete rows
/// numbered 0..frames-1, each with as many cells as the header. Returns the rows.
std::vector<std::vector<std::string>> checkMetrics(const std::string& path, int frames) {
    const std::string text = slurp(path);
    REQUIRE(!text.empty());
    CHECK(text.back() == '\n'); // the last row is complete
    const std::vector<std::string> lines = split(text, '\n');
    REQUIRE(!lines.empty());
    const std::vector<std::string> header = split(lines[0], ',');
    for (const std::string& column : split(kCoreColumns, ',')) {
        INFO("metrics column " << column);
        CHECK(std::count(header.begin(), header.end(), column) == 1);
    }
    CHECK(int(lines.size()) - 1 == frames);
    std::vector<std::vector<std::string>> rows;
    for (std::size_t i = 1; i < lines.size(); ++i) {
        rows.push_back(split(lines[i], ','));
        INFO("metrics row " << i << ": " << lines[i]);
        CHECK(rows.back().size() == header.size());
        CHECK(rows.back()[0] == std::to_string(i - 1));
    }
    return rows;
}

/// Checks that frames 0..frames-1 have both caches, frame `frames` has none, and no temporary
/// file is left anywhere in the output folder.
void checkFrames(const std::string& outDir, int frames) {
    for (int k = 0; k < frames; ++k)
        for (const char* kind : {"particles", "volume"}) {
            const std::string path = outDir + "/" + frameName(kind, k);
            INFO(path);
            CHECK(fs::is_regular_file(path));
            CHECK(isVdbFile(path));
        }
    CHECK_FALSE(fs::exists(outDir + "/" + frameName("particles", frames)));
    CHECK_FALSE(fs::exists(outDir + "/" + frameName("volume", frames)));
    CHECK(temporaryFiles(outDir).empty());
}

void checkSummaryKeys(const std::string& json) {
    CHECK(json.front() == '{');
    CHECK(json.find_last_not_of(" \n") == json.rfind('}'));
    for (const std::string& key : split(kCoreSummaryKeys, ',')) {
        INFO("summary key " << key);
        CHECK_FALSE(jsonValue(json, key).empty());
    }
}

const std::string kGranularScene = std::string(FIRN_SOURCE_DIR) + "/scenes/granular-slide.toml";

/// The usage error text main prints for `message`.
std::string usageError(const std::string& message) {
    return "firn: error: " + message + "\n(see firn --help)\n";
}

/// A scene or usage error: exit code 1, nothing on stdout, exactly `expected` on stderr, and no
/// output folder created by `firn run`.
void checkRejected(const TempDir& dir, std::vector<std::string> args, const std::string& expected) {
    const std::string outDir = dir.path() + "/never";
    if (args[0] == "run") args.insert(args.begin() + 1, {"--out", outDir});
    const Outcome o = runFirn(args, dir);
    std::string line;
    for (const std::string& a : args) line += " " + a;
    INFO("firn" << line);
    CHECK(o.code == 1);
    CHECK(o.out.empty());
    CHECK(o.err == expected);
    CHECK_FALSE(fs::exists(outDir));
}

/// A scene error: one line "file:line:col: error: key: ..." from both `check` and `run`.
void checkSceneError(const TempDir& dir, const std::string& name, const std::string& text,
                     const std::string& expected, const std::vector<std::string>& extra = {}) {
    const std::string path = dir.path() + "/" + name;
    writeText(path, text);
    for (const char* command : {"check", "run"}) {
        std::vector<std::string> args = {command, path};
        args.insert(args.end(), extra.begin(), extra.end());
        checkRejected(dir, args, expected + "\n");
    }
}

} // namespace

TEST_CASE("Every bad scene gives exit code 1 and one message with file:line:col and key", "[cli]") {
    TempDir dir("firn-cli-errors");
    const std::string d = dir.path() + "/";

    // The scene itself is fine: the tests below each break one thing.
    REQUIRE(runFirn({"check", d + "tiny.toml"}, dir).code == 1); // not written yet
    writeText(d + "tiny.toml", kTiny);
    const Outcome checked = runFirn({"check", d + "tiny.toml"}, dir);
    REQUIRE(checked.code == 0);
    // Durations print as the scene wrote them, not as std::to_string's "2.000000".
    CHECK_THAT(checked.out, Catch::Contains("settles under gravity before t = 0 (at most 2 s of "
                                            "settling)"));

    SECTION("TOML syntax error") {
        const std::string path = d + "syntax.toml";
        writeText(path, withLine(kTiny, 8, "dx = = 0.1"));
        for (const char* command : {"check", "run"}) {
            std::vector<std::string> args = {command, path};
            if (args[0] == "run") args.insert(args.end(), {"--out", d + "never"});
            const Outcome o = runFirn(args, dir);
            INFO(command);
            CHECK(o.code == 1);
            CHECK(o.out.empty());
            // The message, then the line with a caret under the column (3 lines).
            CHECK(o.err == path + ":8:6: error: grid.dx: syntax error: Error while parsing "
                                  "value: could not determine value type\n"
                                  " 8 | dx = = 0.1\n"
                                  "   |      ^\n");
            CHECK_FALSE(fs::exists(d + "never"));
        }
    }
    SECTION("unknown key") {
        checkSceneError(dir, "unknown.toml", withLine(kTiny, 9, "particles_per_cel = 4"),
                        d + "unknown.toml:9:1: error: grid.particles_per_cel: unknown key; did "
                            "you mean 'particles_per_cell'?");
    }
    SECTION("wrong type") {
        checkSceneError(dir, "type.toml", withLine(kTiny, 8, "dx = \"fine\""),
                        d + "type.toml:8:6: error: grid.dx: must be a number, got string");
    }
    SECTION("value out of range") {
        checkSceneError(dir, "range.toml", withLine(kTiny, 14, "poisson_ratio = 0.7"),
                        d + "range.toml:14:17: error: material \"snow\": poisson_ratio: must be "
                            "in [0, 0.5), got 0.7");
    }
    SECTION("a body naming an undefined material") {
        checkSceneError(dir, "material.toml", withLine(kTiny, 21, "material = \"slush\""),
                        d + "material.toml:21:12: error: body 1: material \"slush\" is not "
                            "defined (materials: snow)");
    }
    SECTION("missing heightfield file") {
        checkSceneError(dir, "dem.toml", kMissingDem,
                        d + "dem.toml:11:8: error: terrain 1: file: file not found: " + d +
                            "missing.asc");
    }
    SECTION("missing scene file") {
        for (const char* command : {"check", "run"})
            checkRejected(dir, {command, d + "absent.toml"},
                          d + "absent.toml: error: cannot open scene file\n");
    }
    SECTION("bad --set") {
        const std::string path = d + "tiny.toml";
        for (const char* command : {"check", "run"}) {
            checkRejected(dir, {command, path, "--set", "grid.dxx=0.2"},
                          "--set: error: grid.dxx: unknown key; did you mean 'dx'?\n");
            checkRejected(dir, {command, path, "--set", "material.slush.density=100"},
                          "--set: error: material.slush.density: no [[material]] named "
                          "\"slush\" (named: snow)\n");
            checkRejected(dir, {command, path, "--set", "grid.dx=-1"},
                          "--set: error: grid.dx: must be > 0, got -1\n");
            checkRejected(dir, {command, path, "--set"}, usageError("--set needs a value"));
        }
    }
    SECTION("bad --threads") {
        const std::string path = d + "tiny.toml";
        for (const std::string n : {"0", "-2", "x", "2x", "1.5", ""})
            checkRejected(dir, {"run", path, "--threads", n},
                          usageError("--threads must be a positive integer, got '" + n + "'"));
        checkRejected(dir, {"run", path, "--threads"}, usageError("--threads needs a value"));
    }
    SECTION("unknown option, command or arguments") {
        const std::string path = d + "tiny.toml";
        checkRejected(dir, {"run", path, "--bogus"},
                      usageError("unknown option '--bogus' for firn run"));
        checkRejected(dir, {"check", path, "--threads", "2"},
                      usageError("unknown option '--threads' for firn check"));
        checkRejected(dir, {"check", path, "--quiet"},
                      usageError("unknown option '--quiet' for firn check"));
        checkRejected(dir, {"simulate", path}, usageError("unknown command 'simulate'"));
        checkRejected(dir, {"run", path, path},
                      usageError("one scene file only, got '" + path + "' and '" + path + "'"));
        checkRejected(dir, {"run", "--quiet"}, usageError("firn run needs a scene file"));
        const Outcome bare = runFirn({}, dir);
        CHECK(bare.code == 1);
        CHECK(bare.out.empty());
        CHECK(bare.err.find("usage:") != std::string::npos);
    }
}

TEST_CASE("firn --help and the command helps exit 0 and list every option", "[cli]") {
    TempDir dir("firn-cli-help");
    const Outcome top = runFirn({"--help"}, dir);
    const Outcome run = runFirn({"run", "--help"}, dir);
    const Outcome check = runFirn({"check", "-h"}, dir);
    const Outcome version = runFirn({"--version"}, dir);
    for (const Outcome* o : {&top, &run, &check, &version}) {
        CHECK(o->code == 0);
        CHECK(o->err.empty());
    }
    for (const char* option : {"--threads", "--out", "--set", "--quiet", "--max-memory"}) {
        INFO(option);
        CHECK(top.out.find(option) != std::string::npos);
        CHECK(run.out.find(option) != std::string::npos);
    }
    CHECK(top.out.find("firn check") != std::string::npos);
    CHECK(top.out.find("130") != std::string::npos); // exit codes are documented
    CHECK(run.out.find("--help") != std::string::npos);
    // check takes --set only; its help says so and lists no run option.
    CHECK(check.out.find("--set") != std::string::npos);
    CHECK(check.out.find("--threads") == std::string::npos);
    CHECK(std::regex_search(version.out, std::regex("^firn [0-9]+\\.[0-9]+\\.[0-9]+\n$")));
}

TEST_CASE("firn check prints particles and dx and a step estimate that --set changes", "[cli]") {
    TempDir dir("firn-cli-check");
    struct Printed {
        long particles = -1, perBody = -1, steps = -1, frames = -1;
        double dt = 0, endTime = 0;
        std::string dx;
    };
    auto check = [&](const std::vector<std::string>& extra) {
        std::vector<std::string> args = {"check", kGranularScene};
        args.insert(args.end(), extra.begin(), extra.end());
        const Outcome o = runFirn(args, dir);
        INFO(o.out << o.err);
        CHECK(o.code == 0);
        CHECK(o.err.empty());
        Printed p;
        std::smatch m;
        if (std::regex_search(o.out, m, std::regex("dx = ([0-9.e-]+) m"))) p.dx = m[1];
        if (std::regex_search(o.out, m, std::regex("\\n  ([0-9]+) particles in ")))
            p.particles = std::stol(m[1]);
        if (std::regex_search(o.out, m, std::regex("body 1 \\(snow\\): ([0-9]+) particles")))
            p.perBody = std::stol(m[1]);
        if (std::regex_search(o.out, m, std::regex("dt <= ([0-9.e+-]+) s"))) p.dt = std::stod(m[1]);
        if (std::regex_search(o.out, m,
                              std::regex("end time ([0-9.e+-]+) s: about ([0-9]+) steps"))) {
            p.endTime = std::stod(m[1]);
            p.steps = std::stol(m[2]);
        }
        if (std::regex_search(o.out, m, std::regex(", ([0-9]+) frames\n")))
            p.frames = std::stol(m[1]);
        return p;
    };
    const Printed base = check({});
    CHECK(base.dx == "0.1");
    CHECK(base.particles > 1000);
    CHECK(base.perBody == base.particles); // the default scene has one body
    CHECK(base.endTime == 4.0);
    CHECK(base.frames == 49); // 4 s at 12 frames/s, plus frame 0
    REQUIRE(base.dt > 0);
    CHECK(base.steps > 1000);
    CHECK(base.steps == Approx(base.endTime / base.dt).epsilon(1e-3));

    const Printed coarse = check({"--set", "grid.dx=0.2"});
    CHECK(coarse.dx == "0.2");
    CHECK(coarse.particles > 0);
    CHECK(coarse.particles != base.particles);
    // Twice the spacing in 2D: about a quarter of the particles.
    CHECK(double(base.particles) / coarse.particles == Approx(4.0).epsilon(0.15));
    CHECK(coarse.steps == Approx(coarse.endTime / coarse.dt).epsilon(1e-3));
    CHECK(coarse.steps < base.steps);

    const Printed longer = check({"--set", "simulation.end_time=8"});
    CHECK(longer.endTime == 8.0);
    CHECK(longer.particles == base.particles);
    CHECK(longer.frames == 97);
    CHECK(longer.steps == Approx(2.0 * base.steps).epsilon(1e-3));
}

// A PST-like slab on a weak layer, both given by density alone (snow parameter table).
const std::string kDensityOnly = R"([simulation]
name = "table"
dimension = 2

[grid]
dx = 0.05

[[material]]
name = "slab"
model = "snow"
density = 250.0

[[material]]
name = "weak"
model = "weak_layer"

[[terrain]]
shape = "plane"
point = [0.0, 0.0]
normal = [0.0, 1.0]

[[body]]
name = "weak"
material = "weak"
shape = "layer"
thickness = 0.1
x_range = [0.0, 1.0]

[[body]]
material = "slab"
shape = "layer"
on_top_of = "weak"
thickness = 0.3
x_range = [0.0, 1.0]
)";

TEST_CASE("firn check prints each material's values and where each came from",
          "[cli][snow_parameters]") {
    TempDir dir("firn-cli-table");
    const std::string path = dir.path() + "/table.toml";
    writeText(path, kDensityOnly);
    const Outcome o = runFirn({"check", path, "--set", "material.weak.softening=50"}, dir);
    INFO(o.out << o.err);
    REQUIRE(o.code == 0);
    auto shows = [&](const std::string& line) {
        return std::regex_search(o.out, std::regex("\\n    " + line + "\\n"));
    };
    CHECK(o.out.find("  material \"slab\" (snow):\n") != std::string::npos);
    CHECK(shows("density +250 kg/m\\^3 +scene file line 11"));
    CHECK(shows("youngs_modulus +4\\.816e\\+06 Pa +table: E = 0\\.93 rho\\^2\\.8 Pa, "
                "van Herwijnen et al\\. 2016 \\(J\\. Glaciol\\. 62:997\\)"));
    CHECK(shows("initial_p0 +2\\.244e\\+04 Pa +table: p0 on the ellipse \\(beta, M\\) from "
                "sigma_t = 240 kPa \\(rho/917\\)\\^2\\.44, Sigrist 2006 \\(ETH thesis\\)"));
    CHECK(shows("hardening +0\\.5 +table: Firn PST calibration, docs/snow.md"));
    CHECK(o.out.find("  material \"weak\" (weak_layer):\n") != std::string::npos);
    CHECK(shows("density +100 kg/m\\^3 +default"));
    CHECK(shows("initial_p0 +6900 Pa +table: .*Firn PST calibration at 100 kg/m\\^3.*"));
    CHECK(shows("softening +50 +--set"));
    CHECK(shows("softening_length +0\\.06 m +table: the PST layer alpha was calibrated on .*"));
    // At the scene's dx (0.05) the crack band is thicker than 0.06 m: alpha as given, no line.
    CHECK(o.out.find("softening at this dx") == std::string::npos);
    // The collapse fills the 0.1 m layer (6 dx = 0.3 m): with alpha 50 it dissipates
    // (0.1 / 50) / (0.06 / 100) = 3.33 times the table's energy per area; alpha 167 would match.
    CHECK(shows("collapse energy per area +3\\.33 x +body \"weak\" \\(0\\.1 m\\) against the "
                "table's 0\\.06 m layer at softening 100: a band of 0\\.1 m .*"));
    CHECK(shows("softening for the table's +167 +gives body \"weak\" the table's collapse "
                "energy per area .*"));

    // Refined to dx 0.005 the band (6 cells, 0.03 m) is half the calibrated layer: alpha halves.
    const Outcome fine = runFirn(
        {"check", path, "--set", "material.weak.softening=50", "--set", "grid.dx=0.005"}, dir);
    INFO(fine.out << fine.err);
    REQUIRE(fine.code == 0);
    CHECK(std::regex_search(fine.out, std::regex("\\n    softening at this dx +25 +crack band: "
                                                 "softening x 6 dx / softening_length\\n")));
    // There the band is 6 cells (0.03 m) of the 0.1 m layer: (0.03 / 25) / (0.06 / 100) = 2.
    CHECK(std::regex_search(fine.out, std::regex("\\n    collapse energy per area +2\\.00 x .*"
                                                 "a band of 0\\.03 m .*\\n    softening for "
                                                 "the table's +100 ")));
}

TEST_CASE("firn check says where each saw cut is and which saw makes it", "[cli]") {
    TempDir dir("firn-cli-cut");
    const std::string path = dir.path() + "/cut.toml";
    writeText(path, kDensityOnly + "\n[[cut]]\nlayer = \"weak\"\nfrom_x = 0.8\nlength = 0.25\n");
    const Outcome quasiStatic = runFirn({"check", path}, dir);
    INFO(quasiStatic.out << quasiStatic.err);
    REQUIRE(quasiStatic.code == 0);
    CHECK(quasiStatic.out.find("\n  cut in layer \"weak\": x in [0.8, 1.05] m, quasi-static saw "
                               "(cut before settling)\n") != std::string::npos);
    const Outcome instant = runFirn({"check", path, "--set", "cut.weak.saw=\"instant\""}, dir);
    CHECK(instant.out.find("\n  cut in layer \"weak\": x in [0.8, 1.05] m, instant saw (removed "
                           "at t = 0)\n") != std::string::npos);
}

TEST_CASE("A tiny run writes scene.toml and metrics and summary and every frame", "[cli]") {
    TempDir dir("firn-cli-run");
    const std::string scene = dir.path() + "/tiny.toml";
    writeText(scene, kTiny);
    const std::string out = dir.path() + "/out";

    const Outcome o = runFirn({"run", scene, "--out", out, "--quiet", "--threads", "2"}, dir);
    INFO(o.err);
    REQUIRE(o.code == 0);
    CHECK(o.out.empty());
    CHECK(o.err.empty());

    // scene.toml is the scene as run, and it reads back as the same scene.
    REQUIRE(fs::is_regular_file(out + "/scene.toml"));
    const Outcome again = runFirn({"check", out + "/scene.toml"}, dir);
    CHECK(again.code == 0);
    CHECK(again.out.find("\n  200 particles in ") != std::string::npos);

    const std::string json = slurp(out + "/summary.json");
    checkSummaryKeys(json);
    CHECK(jsonValue(json, "status") == "\"ok\"");
    CHECK(jsonValue(json, "scene") == "\"" + scene + "\"");
    CHECK(jsonValue(json, "dimension") == "2");
    CHECK(jsonValue(json, "particles") == "200");
    CHECK(jsonValue(json, "frames") == "4"); // 0.1 s at 30 frames/s, plus frame 0
    CHECK(jsonValue(json, "threads") == "2");
    CHECK(std::stod(jsonValue(json, "end_time")) == Approx(0.1));
    CHECK(jsonValue(json, "stop_reason") == "\"end_time\""); // a resting box never released
    CHECK(std::stod(jsonValue(json, "mass_initial")) == Approx(125.0)); // 0.5 m^2 * 250 kg/m^3
    CHECK(std::stod(jsonValue(json, "mass_final")) == Approx(125.0));
    CHECK(std::stol(jsonValue(json, "steps")) > 0);

    const auto rows = checkMetrics(out + "/metrics.csv", 4);
    checkFrames(out, 4);
    const std::set<std::string> expected = {"scene.toml",
                                            "terrain.obj",
                                            "terrain.vdb",
                                            "metrics.csv",
                                            "summary.json",
                                            "frames/particles.0000.vdb",
                                            "frames/particles.0001.vdb",
                                            "frames/particles.0002.vdb",
                                            "frames/particles.0003.vdb",
                                            "frames/volume.0000.vdb",
                                            "frames/volume.0001.vdb",
                                            "frames/volume.0002.vdb",
                                            "frames/volume.0003.vdb"};
    CHECK(filesUnder(out) == expected);

    SECTION("without --quiet, progress goes to stderr one line per frame") {
        const std::string out1 = dir.path() + "/out1";
        const Outcome p = runFirn({"run", scene, "--out", out1, "--threads", "1"}, dir);
        REQUIRE(p.code == 0);
        CHECK(p.out.empty());
        CHECK(p.err.find('\r') == std::string::npos); // stderr is a file, not a TTY
        const std::vector<std::string> lines = split(p.err, '\n');
        REQUIRE(lines.size() == 6);
        CHECK(std::regex_match(lines[0], std::regex("seeded [0-9]+ particles in [0-9.]+ s")));
        CHECK(lines[1].rfind("settled under gravity in ", 0) == 0);
        for (int k = 1; k <= 3; ++k) {
            INFO(lines[k + 1]);
            CHECK(lines[k + 1].rfind("frame " + std::to_string(k) + "/3 ", 0) == 0);
        }
        CHECK(lines[5].rfind("firn: 4 frames, ", 0) == 0);
        CHECK(lines[5].find(out1) != std::string::npos);

        // The thread count does not change the results: same metrics but the wall clock.
        const auto rows1 = checkMetrics(out1 + "/metrics.csv", 4);
        const auto header = split(split(slurp(out + "/metrics.csv"), '\n')[0], ',');
        const auto wall = std::find(header.begin(), header.end(), "wall_seconds") - header.begin();
        REQUIRE(rows1.size() == rows.size());
        for (std::size_t i = 0; i < rows.size(); ++i)
            for (std::size_t c = 0; c < rows[i].size() && c < rows1[i].size(); ++c) {
                if (long(c) == wall) continue;
                INFO("row " << i << ", column " << header[c]);
                CHECK(rows1[i][c] == rows[i][c]);
            }
        CHECK(jsonValue(slurp(out1 + "/summary.json"), "threads") == "1");
    }
}

TEST_CASE("A blow-up exits 2 with status unstable and says when and where", "[cli]") {
    TempDir dir("firn-cli-unstable");
    const std::string scene = dir.path() + "/unstable.toml";
    writeText(scene, kUnstable);

    // With a stable CFL number the same block falls quietly past the time the other one blows up.
    const std::string calm = dir.path() + "/calm";
    const Outcome ok = runFirn({"run", scene, "--out", calm, "--quiet", "--set", "grid.cfl=0.4",
                                "--set", "simulation.end_time=0.15"},
                               dir);
    CHECK(ok.code == 0);
    CHECK(jsonValue(slurp(calm + "/summary.json"), "status") == "\"ok\"");

    const std::string out = dir.path() + "/out";
    const Outcome o = runFirn({"run", scene, "--out", out, "--quiet"}, dir);
    INFO(o.err);
    CHECK(o.code == 2);
    CHECK(o.out.empty());
    CHECK(o.err.rfind("firn: unstable: ", 0) == 0);
    CHECK(count(o.err, '\n') == 1);
    std::smatch m;
    REQUIRE(std::regex_search(o.err, m, std::regex("at t = ([0-9.e+-]+) s")));
    const double t = std::stod(m[1]);
    CHECK(t > 0);
    CHECK(t < 0.5);
    CHECK(std::regex_search(o.err, std::regex("near x = \\([^)]+\\) m")));

    const std::string json = slurp(out + "/summary.json");
    checkSummaryKeys(json);
    CHECK(jsonValue(json, "status") == "\"unstable\"");
    const int frames = std::stoi(jsonValue(json, "frames"));
    CHECK(frames >= 1);
    CHECK(frames < 16); // it stopped before the end
    CHECK(jsonValue(json, "message").find("last good frame is " + std::to_string(frames - 1)) !=
          std::string::npos);
    CHECK(o.err.find("last good frame is " + std::to_string(frames - 1)) != std::string::npos);
    // The frames written before the blow-up stay, complete.
    CHECK(fs::is_regular_file(out + "/" + frameName("particles", 0)));
    CHECK(fs::is_regular_file(out + "/scene.toml"));
    checkMetrics(out + "/metrics.csv", frames);
    checkFrames(out, frames);
}

TEST_CASE("SIGINT and SIGTERM stop a run cleanly with exit code 130", "[cli]") {
    TempDir dir("firn-cli-signal");
    for (const int sig : {SIGINT, SIGTERM}) {
        const std::string out = dir.path() + "/out" + std::to_string(sig);
        const Capture cap = captureFiles(dir.path());
        // Two and a half minutes of simulation: it only ends early by the signal.
        const pid_t pid = spawnFirn({"run", kGranularScene, "--out", out, "--threads", "2", "--set",
                                     "simulation.end_time=60"},
                                    cap);
        // Mid-run: header plus frames 0 and 1 written, so the signal handlers are in place.
        // The wait returns as soon as they are there; its limit is generous because the
        // settling stage alone took 23.7 s in an ASan build on a machine running CI beside it.
        const bool started = waitForLines(out + "/metrics.csv", 3, 120.0);
        kill(pid, sig);
        const int code = waitExit(pid, 30.0);
        const std::string err = slurp(cap.err);
        INFO("signal " << sig << "; stderr:\n" << err);
        REQUIRE(started);
        CHECK(code == 130);
        CHECK(err.find("firn: stopped by signal " + std::to_string(sig) + " at t = ") !=
              std::string::npos);
        CHECK(err.find("frames kept in " + out + "\n") != std::string::npos);

        const std::string json = slurp(out + "/summary.json");
        checkSummaryKeys(json);
        CHECK(jsonValue(json, "status") == "\"interrupted\"");
        CHECK(jsonValue(json, "message").find("signal " + std::to_string(sig)) !=
              std::string::npos);
        const int frames = std::stoi(jsonValue(json, "frames"));
        CHECK(frames >= 2);
        CHECK(std::stod(jsonValue(json, "end_time")) < 60.0);
        checkMetrics(out + "/metrics.csv", frames);
        checkFrames(out, frames);
        CHECK(err.find(std::to_string(frames) + " frames kept") != std::string::npos);
    }
}

TEST_CASE("A run that would not fit in memory is refused before anything is written", "[cli]") {
    TempDir dir("firn-cli-memory");
    const std::string scene = dir.path() + "/tiny.toml";
    writeText(scene, kTiny);
    const std::string out = dir.path() + "/out";
    // The tiny scene needs ~70 MB (the process itself) + 400 B a particle: 10 MB cannot hold it.
    const Outcome o = runFirn({"run", scene, "--out", out, "--max-memory", "10M"}, dir);
    INFO(o.err);
    CHECK(o.code == 3);
    CHECK(o.err.rfind("firn: not enough memory: the scene needs about ", 0) == 0);
    CHECK(o.err.find("more than the 10.0 MB of --max-memory") != std::string::npos);
    CHECK_FALSE(fs::exists(out));
    // At dx 0.0005 m the tiny box would be 8e6 particles (3.3 GB): refused from the estimate
    // alone (seeding them would take a while), with the spacing that would fit.
    const Outcome fine =
        runFirn({"run", scene, "--out", out, "--set", "grid.dx=0.0005", "--max-memory", "1G"}, dir);
    CHECK(fine.code == 3);
    CHECK(fine.err.find("A grid.dx of ") != std::string::npos);
    CHECK_FALSE(fs::exists(out));
    // check reports the same estimate without seeding, and says run would refuse it.
    const Outcome check =
        runFirn({"check", scene, "--set", "grid.dx=0.0005", "--max-memory", "1G"}, dir);
    CHECK(check.code == 0);
    CHECK(check.out.find("particles (estimated)") != std::string::npos);
    CHECK(check.out.find("1.0 GB available (--max-memory)") != std::string::npos);
    CHECK(check.out.find("warning: `firn run` would refuse this scene") != std::string::npos);
    // A budget that fits runs; a malformed one is a usage error.
    CHECK(runFirn({"run", scene, "--out", out, "--quiet", "--max-memory", "2G"}, dir).code == 0);
    for (const std::string bad : {"lots", "-1G", "4Q", ""})
        checkRejected(dir, {"run", scene, "--max-memory", bad},
                      usageError("--max-memory: not a size: '" + bad + "' (e.g. 4G, 512M)"));
}

TEST_CASE("An output folder that cannot be written gives exit code 3 and names it", "[cli]") {
    TempDir dir("firn-cli-io");
    const std::string scene = dir.path() + "/tiny.toml";
    writeText(scene, kTiny);
    writeText(dir.path() + "/file", "a regular file, not a folder\n");
    const std::vector<std::string> outs = {"/proc/firn-cannot-write", dir.path() + "/file/sub",
                                           dir.path() + "/file"};
    for (const std::string& out : outs) {
        const Outcome o = runFirn({"run", scene, "--out", out, "--quiet"}, dir);
        INFO(out << ": " << o.err);
        CHECK(o.code == 3);
        CHECK(o.out.empty());
        CHECK(o.err.rfind("firn: I/O error: ", 0) == 0);
        CHECK(o.err.find(out) != std::string::npos);
        CHECK(count(o.err, '\n') == 1);
    }
    CHECK(slurp(dir.path() + "/file") == "a regular file, not a folder\n");
}

// The SIGINT/SIGTERM handlers must be in place before setup: a signal while a large scene is
// seeded still ends with a summary and firn's own exit code.
TEST_CASE("A signal during scene setup still stops the run cleanly", "[cli]") {
    TempDir dir("firn-cli-setup-signal");
    const std::string out = dir.path() + "/out";
    const Capture cap = captureFiles(dir.path());
    // About 230k particles: building the world takes a few tenths of a second.
    const pid_t pid =
        spawnFirn({"run", kGranularScene, "--out", out, "--quiet", "--set", "grid.dx=0.01"}, cap);
    // scene.toml is written just before the world is built.
    bool setup = false;
    for (int i = 0; i < 5000 && !setup; ++i) {
        setup = fs::exists(out + "/scene.toml");
        if (!setup) std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    kill(pid, SIGTERM);
    const int code = waitExit(pid, 60.0);
    INFO(slurp(cap.err));
    REQUIRE(setup);
    CHECK_FALSE(fs::exists(out + "/" + frameName("particles", 1))); // it was still setting up
    CHECK(code == 130);
    CHECK(jsonValue(slurp(out + "/summary.json"), "status") == "\"interrupted\"");
    CHECK(temporaryFiles(out).empty());
}

TEST_CASE("Snow that leaves the domain is removed and counted as outflow", "[cli]") {
    TempDir dir("firn-cli-outflow");
    // A block at rest on the ground (it falls asleep) and one sliding off to +x at 4 m/s on a
    // slip floor; the domain ends at x = 3 m.
    const std::string scene = dir.path() + "/outflow.toml";
    writeText(scene, R"([simulation]
name = "outflow"
dimension = 2
end_time = 1.0
frame_rate = 20
domain_min = [-1.0, -1.0]
domain_max = [3.0, 5.0]

[grid]
dx = 0.1
particles_per_cell = 4

[[material]]
name = "snow"
model = "elastic"

[[terrain]]
shape = "plane"
point = [0.0, 0.0]
normal = [0.0, 1.0]
boundary = "slip"

[[body]]
material = "snow"
shape = "box"
min = [-0.5, 0.0]
max = [0.0, 0.3]

[[body]]
material = "snow"
shape = "box"
min = [1.0, 0.0]
max = [1.4, 0.2]
velocity = [4.0, 0.0]
)");
    const std::string out = dir.path() + "/out";
    const Outcome o = runFirn({"run", scene, "--out", out, "--quiet"}, dir);
    INFO(o.err);
    REQUIRE(o.code == 0);
    const std::string json = slurp(out + "/summary.json");
    const double initial = std::stod(jsonValue(json, "mass_initial"));
    const double final = std::stod(jsonValue(json, "mass_final"));
    const double outflow = std::stod(jsonValue(json, "mass_outflow"));
    // The sliding block (0.4 x 0.2 m of the 0.5 x 0.3 + 0.4 x 0.2 m seeded) left: its mass is
    // outflow, the resting block's stays; the balance closes to float rounding.
    CHECK(outflow == Approx(initial * 0.08 / 0.23).epsilon(0.02));
    CHECK(final + outflow == Approx(initial).epsilon(1e-6));
    CHECK(std::stoi(jsonValue(json, "particles")) == 60); // the resting block's 0.15 m^2
    const std::string metrics = slurp(out + "/metrics.csv");
    CHECK(metrics.rfind("outflow_mass") != std::string::npos);
    // With the slider gone nothing moves: the run ends at rest (simulation.stop_at_rest).
    CHECK(jsonValue(json, "stop_reason") == "\"at_rest\"");
    CHECK(std::stoi(jsonValue(json, "frames")) < 21);
}

TEST_CASE("A run ends itself once the flow is at rest, with the last frame and the summary",
          "[cli][hazard]") {
    TempDir dir("firn-cli-rest");
    // A granular box pushed at 2 m/s along a floor with Coulomb friction 0.5: the floor stops its
    // base within 2 / (0.5 g) = 0.41 s, and the box spreads and comes to rest, far before the
    // 3 s end time.
    const std::string scene = dir.path() + "/rest.toml";
    std::string text = kTiny;
    text.replace(text.find("end_time = 0.1"), 14, "end_time = 3.0");
    text.replace(text.find("frame_rate = 30"), 15, "frame_rate = 20");
    text += "velocity = [2.0, 0.0]\n";
    text.replace(text.find("normal = [0.0, 1.0]\n"), 20, "normal = [0.0, 1.0]\nfriction = 0.5\n");
    writeText(scene, text);
    const std::string out = dir.path() + "/out";
    const Outcome o = runFirn({"run", scene, "--out", out}, dir);
    INFO(o.err);
    REQUIRE(o.code == 0);
    const std::string json = slurp(out + "/summary.json");
    CHECK(jsonValue(json, "status") == "\"ok\"");
    CHECK(jsonValue(json, "stop_reason") == "\"at_rest\"");
    const double end = std::stod(jsonValue(json, "end_time"));
    CHECK(end > 0.4); // not before the base can have stopped
    CHECK(end < 1.5); // half the end time: the stop saved at least that
    CHECK(std::stod(jsonValue(json, "rest_energy_ratio")) < 0.01);
    // The last frame is the stopping time's, on the frame grid; metrics have a row per frame.
    const int frames = std::stoi(jsonValue(json, "frames"));
    CHECK(frames == int(std::lround(end * 20.0)) + 1);
    checkMetrics(out + "/metrics.csv", frames);
    checkFrames(out, frames);
    CHECK(o.err.find("at rest at t=") != std::string::npos);
    CHECK(o.err.find("of peak (stops < 1 %)") != std::string::npos);

    SECTION("with stop_at_rest = false it runs to the end time") {
        const std::string out1 = dir.path() + "/out1";
        const Outcome p = runFirn(
            {"run", scene, "--out", out1, "--quiet", "--set", "simulation.stop_at_rest=false"},
            dir);
        REQUIRE(p.code == 0);
        const std::string json1 = slurp(out1 + "/summary.json");
        CHECK(jsonValue(json1, "stop_reason") == "\"end_time\"");
        CHECK(std::stod(jsonValue(json1, "end_time")) == Approx(3.0));
        CHECK(jsonValue(json1, "frames") == "61");
    }
    SECTION("rest_energy_fraction needs stop_at_rest") {
        const Outcome p = runFirn({"check", scene, "--set", "simulation.stop_at_rest=false",
                                   "--set", "simulation.rest_energy_fraction=0.05"},
                                  dir);
        CHECK(p.code == 1);
        CHECK(p.err.find("rest_energy_fraction") != std::string::npos);
    }
}

TEST_CASE("A file-size limit mid-run exits 3, keeps the frames written and says why", "[cli]") {
    TempDir dir("firn-cli-fsize");
    // A box falling freely for 2 s (60 frames, no terrain, no caches): metrics.csv grows by
    // ~280 bytes a frame and passes a limit of 8 KiB (ulimit -f 16: blocks of 512 bytes in sh)
    // about half way. Past the limit write(2) fails with EFBIG, as it would with ENOSPC on a
    // full disk.
    const std::string scene = dir.path() + "/fall.toml";
    writeText(scene, R"([simulation]
name = "fall"
dimension = 2
end_time = 2.0
frame_rate = 30

[grid]
dx = 0.1
particles_per_cell = 4

[output]
particles = false
volumes = []

[[material]]
name = "snow"
model = "elastic"

[[body]]
material = "snow"
shape = "box"
min = [0.0, 0.0]
max = [0.5, 0.5]
)");
    const std::string out = dir.path() + "/out";
    const Outcome o = runShell(
        "ulimit -f 16 && exec \"$FIRN\" run '" + scene + "' --out '" + out + "' --quiet", dir);
    INFO(o.err);
    CHECK(o.code == 3);
    CHECK(o.err.rfind("firn: I/O error: cannot write " + out + "/metrics.csv: File too large; " +
                          "last complete frame is ",
                      0) == 0);
    const std::string json = slurp(out + "/summary.json");
    CHECK(jsonValue(json, "status") == "\"io_error\"");
    CHECK(jsonValue(json, "message").find("File too large") != std::string::npos);
    const int frames = std::stoi(jsonValue(json, "frames"));
    CHECK(frames > 5);
    CHECK(frames < 61);
    // Every row the summary counts is on disk and whole (the row cut by the limit is removed);
    // nothing half written is left.
    const std::string metrics = slurp(out + "/metrics.csv");
    CHECK(count(metrics, '\n') == frames + 1);
    CHECK(metrics.back() == '\n');
    CHECK(temporaryFiles(out).empty());
}

TEST_CASE("firn check names the slip surface, its bodies and its friction", "[cli][slip]") {
    TempDir dir("firn-cli-check-slip");
    const std::string scene = std::string(FIRN_SOURCE_DIR) + "/bench/slab_drag.toml";
    const Outcome plain = runFirn({"check", scene}, dir);
    CHECK(plain.code == 0);
    CHECK(plain.out.find("slip surface") == std::string::npos);
    const Outcome slip = runFirn({"check", scene, "--set", "body.slab.slides_on=\"weak\"", "--set",
                                  "body.block.slides_on=\"weak\""},
                                 dir);
    INFO(slip.out << slip.err);
    CHECK(slip.code == 0);
    // M_d 1.2 from the parameter table: 1.2 / sqrt(3) = 0.6928.
    CHECK(slip.out.find("  slip surface on weak layer \"weak\", bodies above: \"slab\", \"block\"; "
                        "friction 0.693 (default: M_d / sqrt(3) of the layer)\n") !=
          std::string::npos);
    const Outcome given = runFirn({"check", scene, "--set", "body.slab.slides_on=\"weak\"", "--set",
                                   "body.slab.slip_friction=0.4"},
                                  dir);
    CHECK(given.out.find("bodies above: \"slab\"; friction 0.4 (scene)\n") != std::string::npos);
    // XPIC keeps one velocity field: a slip surface with it is an error at the body's key.
    const Outcome xpic = runFirn({"check", scene, "--set", "grid.transfer=\"xpic\"", "--set",
                                  "body.slab.slides_on=\"weak\""},
                                 dir);
    INFO(xpic.err);
    CHECK(xpic.code != 0);
    CHECK(xpic.err.find("slides_on: a slip surface needs grid.transfer \"apic\", \"pic\" or "
                        "\"flip\" (\"xpic\" keeps one velocity field)") != std::string::npos);
}

TEST_CASE("firn check notes a weak layer fewer than 4 cells thick", "[cli]") {
    // bench/slab_drag.toml: a 0.2 m weak layer at dx 0.05 (4 cells: no note) and at dx 0.1
    // (2 cells: the crack's speed depends on the layer's softening there, docs/slope-scale.md).
    TempDir dir("firn-cli-check-cells");
    const std::string scene = std::string(FIRN_SOURCE_DIR) + "/bench/slab_drag.toml";
    const Outcome fine = runFirn({"check", scene}, dir);
    CHECK(fine.code == 0);
    CHECK(fine.out.find("cells thick") == std::string::npos);
    const Outcome coarse = runFirn({"check", scene, "--set", "grid.dx=0.1"}, dir);
    INFO(coarse.out << coarse.err);
    CHECK(coarse.code == 0);
    CHECK(coarse.out.find("  body 2 \"weak\" (weak): ") != std::string::npos);
    CHECK(coarse.out.find(" particles\n    note: the weak layer is 2 cells thick; below 4 the "
                          "crack's speed depends on its `softening`") != std::string::npos);
    // Only the weak layer gets it: the 0.15 m base is 1.5 cells.
    CHECK(coarse.out.find("cells thick") == coarse.out.rfind("cells thick"));
}
