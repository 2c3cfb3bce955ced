// firn compare: scene diffs, tolerances and difference images on small inputs; then two runs of
// a tiny scene compared end to end (identical, one changed parameter, another scene).
#include "cli/compare_command.h"
#include "test_util.h"

#include <firn/compare.h>
#include <firn/errors.h>
#include <firn/run.h>

#include <firn_test_paths.h>

#include <catch2/catch.hpp>

#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

using namespace firn;
using firn::test::TempDir;
namespace fs = std::filesystem;

namespace {

const std::string& kTiny = firn::test::kTinyScene;

const std::string kSecondBody = R"(
[[body]]
material = "snow"
shape = "box"
min = [2.0, 0.0]
max = [2.5, 0.5]
)";

void writeText(const std::string& path, const std::string& text) {
    std::ofstream(path, std::ios::binary) << text;
}

std::string slurp(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

/// Runs `sceneText` with `overrides` into DIR/name; returns the output folder.
std::string runTiny(const TempDir& dir, const std::string& name, const std::string& sceneText,
                    const std::vector<std::string>& overrides = {}) {
    const std::string scenePath = dir.path() + "/" + name + ".toml";
    writeText(scenePath, sceneText);
    RunOptions options;
    options.outDir = dir.path() + "/" + name;
    options.quiet = true;
    options.threads = 2;
    REQUIRE(runScene(loadScene(scenePath, overrides), options).status == "ok");
    return options.outDir;
}

struct Outcome {
    int code = -1;
    std::string out, err;
};

/// Runs the firn binary with `args` (paths without shell metacharacters) and captures it.
Outcome runFirn(const TempDir& dir, const std::string& args) {
    const std::string out = dir.path() + "/stdout", err = dir.path() + "/stderr";
    const int status =
        std::system((std::string(FIRN_BINARY) + " " + args + " >" + out + " 2>" + err).c_str());
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(out), slurp(err)};
}

const FigureComparison& figure(const CompareResult& r, const std::string& source,
                               const std::string& name) {
    const auto it = std::find_if(r.figures.begin(), r.figures.end(), [&](const auto& f) {
        return f.source == source && f.name == name;
    });
    INFO(source << " " << name);
    REQUIRE(it != r.figures.end());
    return *it;
}

int distinctColours(const Image& image) {
    std::set<int> colours;
    for (int y = 0; y < image.height; ++y)
        for (int x = 0; x < image.width; ++x) {
            const std::uint8_t* p = image.pixel(x, y);
            colours.insert(p[0] << 16 | p[1] << 8 | p[2]);
        }
    return int(colours.size());
}

} // namespace

TEST_CASE("Scene differences: dimension and entity kinds are structural, values are not",
          "[compare]") {
    TempDir dir("firn-compare-scenes");
    const std::string a = dir.path() + "/a.toml", b = dir.path() + "/b.toml";
    writeText(a, kTiny + "\n[output]\ndirectory = \"out/one\"\n");

    SECTION("the same scene written elsewhere: no difference") {
        writeText(b, kTiny + "\n[output]\ndirectory = \"out/two\"\n");
        CHECK(diffScenes(a, b).empty());
    }
    SECTION("a changed value and a renamed run are parameters of the same scene") {
        std::string text = kTiny;
        text.replace(text.find("name = \"tiny\""), 13, "name = \"other\"");
        text.replace(text.find("dx = 0.1"), 8, "dx = 0.05");
        writeText(b, text);
        const auto d = diffScenes(a, b);
        REQUIRE(d.size() == 2);
        CHECK(d[0].key == "grid.dx");
        CHECK(d[0].a == "0.1");
        CHECK(d[0].b == "0.05");
        CHECK_FALSE(d[0].structural);
        CHECK(d[1].key == "simulation.name");
        CHECK_FALSE(d[1].structural);
    }
    SECTION("another dimension, another body or another shape make another scene") {
        std::string text = kTiny + kSecondBody;
        text.replace(text.find("dimension = 2"), 13, "dimension = 3");
        text.replace(text.find("shape = \"plane\""), 15, "shape = \"profile\"");
        writeText(b, text);
        std::set<std::string> structural;
        for (const SceneDifference& d : diffScenes(a, b))
            if (d.structural) structural.insert(d.key);
        CHECK(structural.count("simulation.dimension"));
        CHECK(structural.count("body"));
        CHECK(structural.count("body[1].shape"));
        CHECK(structural.count("terrain[0].shape"));
    }
    SECTION("a named material only one scene has is structural, named by its name") {
        writeText(b, kTiny + "[[material]]\nname = \"slab\"\nmodel = \"snow\"\n");
        bool found = false;
        for (const SceneDifference& d : diffScenes(a, b)) {
            if (d.key == "material.slab.model") {
                found = true;
                CHECK(d.structural);
                CHECK(d.a == "(absent)");
            }
        }
        CHECK(found);
    }
    SECTION("a syntax error names the file and line") {
        writeText(b, "[simulation\n");
        CHECK_THROWS_AS(diffScenes(a, b), SceneError);
        CHECK_THROWS_WITH(diffScenes(a, b), Catch::Contains("b.toml:1"));
    }
}

TEST_CASE("Tolerances: documented defaults, relative and absolute, bad specs refused",
          "[compare]") {
    ToleranceTable t = ToleranceTable::defaults();
    CHECK(t.lookup("max_speed").value == 0.01);
    CHECK_FALSE(t.lookup("max_speed").absolute);
    CHECK(t.lookup("alpha_angle_deg").absolute);
    CHECK(t.lookup("pixels").value == 0.01);
    t.set("max_speed=0.05");
    t.set("runout_x=abs:0.2");
    CHECK(t.lookup("max_speed").value == 0.05);
    CHECK(t.lookup("runout_x").absolute);
    CHECK(t.lookup("runout_x").value == 0.2);
    t.set("all=0.1");
    CHECK(t.lookup("max_speed").value == 0.1);
    CHECK(t.lookup("mass").value == 0.1);
    CHECK_THROWS_WITH(t.set("max_speed"), Catch::Contains("name=value"));
    CHECK_THROWS_WITH(t.set("max_speed=fast"), Catch::Contains("max_speed"));
    CHECK_THROWS_WITH(t.set("max_speed=-1"), Catch::Contains(">= 0"));
    CHECK_THROWS_WITH(cli::parseCompareCommand({"a"}), Catch::Contains("two output folders"));
    CHECK_THROWS_WITH(cli::parseCompareCommand({"a", "b", "--size", "64"}),
                      Catch::Contains("WIDTHxHEIGHT"));
    const auto c = cli::parseCompareCommand(
        {"a", "b", "--tolerance", "front_x=abs:0.5", "--force", "--frame-step", "2"});
    CHECK(c.options.force);
    CHECK(c.options.frameStep == 2);
    CHECK(c.options.tolerances.lookup("front_x").absolute);
}

TEST_CASE("Difference images are black exactly where two frames agree", "[compare]") {
    Image a(8, 4, {100, 150, 200}), b = a;
    b.pixel(2, 1)[0] = 103; // below the threshold: differs, but is no change
    b.pixel(5, 3)[2] = 250; // a change
    b.pixel(6, 0)[1] = 0;   // a change
    const Image d = differenceImage(a, b);
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 8; ++x) {
            const std::uint8_t* p = d.pixel(x, y);
            const bool black = p[0] == 0 && p[1] == 0 && p[2] == 0;
            const bool equal = std::equal(a.pixel(x, y), a.pixel(x, y) + 3, b.pixel(x, y));
            INFO(x << "," << y);
            CHECK(black == equal);
        }
    const FrameComparison c = compareImages(a, b);
    CHECK(c.changedFraction == Approx(2.0 / 32));
    CHECK(c.maxChannelDifference == 150);
    CHECK(compareImages(a, a).maxChannelDifference == 0);
    CHECK_THROWS_WITH(differenceImage(a, Image(4, 4)), Catch::Contains("different sizes"));
}

TEST_CASE("One scene run twice compares identical, exit code 0", "[compare][e2e]") {
    TempDir dir("firn-compare-same");
    const std::string a = runTiny(dir, "a", kTiny), b = runTiny(dir, "b", kTiny);
    const Outcome o = runFirn(dir, "compare " + a + " " + b + " --quiet --size 320x180");
    INFO(o.out << o.err);
    CHECK(o.code == 0);
    CHECK(o.out.rfind("identical:", 0) == 0);
    const std::string page = slurp(b + "/compare/compare.html");
    CHECK(page.find("Verdict: identical") != std::string::npos);
    CHECK(page.find("data:image/png;base64,") != std::string::npos);

    // Both renders drawn, the same size, and their difference black everywhere.
    const Image first = readPng(b + "/compare/a/frame.0003.png");
    const Image second = readPng(b + "/compare/b/frame.0003.png");
    CHECK(first.width == 320);
    CHECK(second.width == 320);
    CHECK(distinctColours(first) > 20); // sky, ground, snow, text: not a blank image
    CHECK(first.rgb == second.rgb);
    const Image diff = readPng(b + "/compare/diff/diff.0003.png");
    CHECK(std::all_of(diff.rgb.begin(), diff.rgb.end(), [](std::uint8_t v) { return v == 0; }));
    CHECK(fs::exists(b + "/compare/contact.png"));
}

TEST_CASE("A changed parameter moves the right figures and frames, exit code 5", "[compare][e2e]") {
    TempDir dir("firn-compare-changed");
    const std::string a = runTiny(dir, "a", kTiny);
    const std::string b = runTiny(dir, "b", kTiny, {"material.snow.friction_angle=20"});
    CompareOptions options;
    options.runA = a;
    options.runB = b;
    options.outDir = dir.path() + "/cmp";
    options.quiet = true;
    options.renderOverrides = {"render.width=320", "render.height=180"};
    const CompareResult r = compareRuns(options);
    CHECK(r.verdict == "moved");
    CHECK(r.exitCode() == 5);
    CHECK_FALSE(r.caches.identical);
    REQUIRE(r.sceneDifferences.size() == 1);
    CHECK(r.sceneDifferences[0].key == "material.snow.friction_angle");
    CHECK_FALSE(r.sceneDifferences[0].structural);

    // Less friction: the box spreads faster. Mass is untouched; timings are not compared.
    CHECK(figure(r, "summary", "max_speed").moved);
    CHECK(figure(r, "metrics", "kinetic_energy").moved);
    CHECK(figure(r, "metrics", "kinetic_energy").relChange > 0.1);
    CHECK(figure(r, "summary", "mass_final").identical);
    CHECK_FALSE(figure(r, "metrics", "mass").moved);
    CHECK_FALSE(figure(r, "summary", "wall_seconds").checked);
    CHECK_FALSE(figure(r, "summary", "wall_seconds").moved);
    // The box's edge settles under its own weight beyond its strength in both runs, by a count
    // per material that the friction changes: listed, compared as settle_overloaded_particles.
    CHECK(figure(r, "summary", "settle_overloaded_particles").checked);
    CHECK_FALSE(figure(r, "summary", "settle_overloaded_by_material").identical);
    CHECK_FALSE(figure(r, "summary", "settle_overloaded_by_material").checked);
    CHECK(figure(r, "frames", "pixels").moved);

    // Same framing for both; the last frame differs, and its difference image is black exactly
    // where the two renders agree.
    REQUIRE(r.frames.size() == 4);
    CHECK(r.frames.back().changedFraction > 0.001);
    const Image first = readPng(options.outDir + "/a/frame.0003.png");
    const Image second = readPng(options.outDir + "/b/frame.0003.png");
    const Image diff = readPng(options.outDir + "/diff/diff.0003.png");
    REQUIRE(first.width == second.width);
    REQUIRE(first.height == second.height);
    REQUIRE(diff.width == first.width);
    int agreeing = 0, wrong = 0;
    for (int y = 0; y < first.height; ++y)
        for (int x = 0; x < first.width; ++x) {
            const bool equal =
                std::equal(first.pixel(x, y), first.pixel(x, y) + 3, second.pixel(x, y));
            const std::uint8_t* d = diff.pixel(x, y);
            agreeing += equal;
            wrong += equal != (d[0] == 0 && d[1] == 0 && d[2] == 0);
        }
    // The camera frames the snow, which moves everywhere; the sky above it and the time label
    // agree.
    CHECK(agreeing > 1000);
    CHECK(agreeing < first.width * first.height);
    CHECK(wrong == 0);

    // The page marks what moved, and a generous tolerance lets the same runs pass.
    const std::string page = slurp(options.outDir + "/compare.html");
    CHECK(page.find("Verdict: moved") != std::string::npos);
    CHECK(page.find("material.snow.friction_angle") != std::string::npos);
    options.tolerances.set("all=abs:1e9");
    const CompareResult loose = compareRuns(options);
    CHECK(loose.verdict == "within tolerance");
    CHECK(loose.exitCode() == 0);
}

TEST_CASE("Runs of different scenes are refused naming the keys, and --force compares them",
          "[compare][e2e]") {
    TempDir dir("firn-compare-other");
    const std::string a = runTiny(dir, "a", kTiny), b = runTiny(dir, "b", kTiny + kSecondBody);
    const Outcome refused = runFirn(dir, "compare " + a + " " + b + " --quiet");
    CHECK(refused.code == 1);
    CHECK(refused.out.empty());
    CHECK(refused.err.find("different scenes") != std::string::npos);
    CHECK(refused.err.find("body[1].shape") != std::string::npos);
    CHECK(refused.err.find("--force") != std::string::npos);
    CHECK_FALSE(fs::exists(b + "/compare"));

    const Outcome forced =
        runFirn(dir, "compare " + a + " " + b + " --quiet --force --size 160x90");
    INFO(forced.err);
    CHECK(forced.code == 5);
    CHECK(forced.out.find("moved summary particles") != std::string::npos);
    CHECK(fs::exists(b + "/compare/compare.html"));

    const Outcome missing = runFirn(dir, "compare " + a + " " + dir.path() + "/nowhere");
    CHECK(missing.code == 3);
    CHECK(missing.err.find("nowhere") != std::string::npos);
}

TEST_CASE("firn compare --help lists every option, the tolerances and the exit codes",
          "[compare]") {
    TempDir dir("firn-compare-help");
    const Outcome o = runFirn(dir, "compare --help");
    CHECK(o.code == 0);
    for (const char* word : {"--out", "--force", "--tolerance", "abs:", "--color-by",
                             "--color-range", "--size", "--frame-step", "--threads", "--quiet",
                             "alpha_angle_deg", "pixels", "5 a figure moved"}) {
        INFO(word);
        CHECK(o.out.find(word) != std::string::npos);
    }
    CHECK(runFirn(dir, "--help").out.find("firn compare RUN_A RUN_B") != std::string::npos);
    CHECK(runFirn(dir, "compare onlyone").code == 1);
}
