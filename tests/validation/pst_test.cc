// validation.md V8: the Propagation Saw Test with the snow and weak-layer models
// (scenes/pst.toml, shortened to a 3 m column where only onset matters).
#include "test_util.h"

#include <firn_test_paths.h>

#include <firn/diagnostics.h>
#include <firn/run.h>

#include <catch2/catch.hpp>

#include <fstream>
#include <regex>
#include <sstream>

using namespace firn;

namespace {

const std::string kPst = std::string(FIRN_SOURCE_DIR) + "/scenes/pst.toml";

/// The PST scene with a 3 m column and the given cut, run in-process for `endTime`.
FrameDiagnostics runShortColumn(double cutLength, double endTime) {
    const SceneDesc scene =
        loadScene(kPst, {"body.weak.x_range=[0.0, 3.0]", "body.slab.x_range=[0.0, 3.0]",
                         "cut.weak.length=" + std::to_string(cutLength)});
    auto world = buildWorld(scene);
    test::advanceTo(*world, endTime);
    return computeDiagnostics(*world);
}

/// True when the crack runs (nearly) to the far end of the 3 m column.
bool propagates(double cutLength) {
    const FrameDiagnostics d = runShortColumn(cutLength, 0.2);
    return !std::isnan(d.crackMaxX) && d.crackMaxX > 2.9;
}

double summaryNumber(const std::string& path, const std::string& key) {
    std::ifstream in(path);
    std::stringstream text;
    text << in.rdbuf();
    std::smatch m;
    const std::string s = text.str();
    REQUIRE(std::regex_search(s, m, std::regex("\"" + key + "\": ([-0-9.eE+]+)")));
    return std::stod(m[1]);
}

} // namespace

TEST_CASE("V8 PST: a short cut stays put, a long cut runs the column", "[validation][pst]") {
    // The crack is where weak-layer particles have softened (eta > 0).
    const FrameDiagnostics shortCut = runShortColumn(0.15, 0.2);
    const double reach = std::isnan(shortCut.crackMaxX) ? 0.0 : shortCut.crackMaxX - 0.15;
    INFO("cut 0.15 m: crack reaches " << reach << " m past the cut");
    // Below critical the failure stays in the cut tip's neighbourhood: within 5 cells.
    REQUIRE(reach < 0.1);

    const FrameDiagnostics longCut = runShortColumn(0.8, 0.2);
    INFO("cut 0.8 m: crack from " << longCut.crackMinX << " to " << longCut.crackMaxX << " m");
    REQUIRE(longCut.crackMaxX > 2.9);  // the whole 3 m column
    REQUIRE(longCut.crackMinX < 0.85); // starting at the cut tip
}

TEST_CASE("V8 PST: the critical cut length on flat ground is in the field range",
          "[validation][pst]") {
    // Bisection on the cut length between a cut that stays and one that runs.
    double stays = 0.15, runs = 0.8;
    REQUIRE_FALSE(propagates(stays));
    REQUIRE(propagates(runs));
    for (int i = 0; i < 3; ++i) {
        const double mid = 0.5 * (stays + runs);
        (propagates(mid) ? runs : stays) = mid;
    }
    const double ac = 0.5 * (stays + runs);
    INFO("a_c in [" << stays << ", " << runs << "] m; closed form (V8) 1.13 m");
    // validation.md V8 gate: absolute a_c within the field range 0.1-1 m. (The closed form of
    // Gaume et al. 2017a gives 1.13 m for these parameters; this model fails the weak layer in
    // compression under the bending slab and measures about a third of that: README "Snow".)
    REQUIRE(ac > 0.1);
    REQUIRE(ac < 1.0);
}

TEST_CASE("V8 PST: the steady crack speed on flat ground is field-like", "[validation][pst]") {
    // The full 6 m column of scenes/pst.toml: a steady speed needs > 4-5 m of propagation.
    test::TempDir dir("firn-pst");
    const SceneDesc scene = loadScene(
        kPst, {"output.particles=false", "output.volumes=[]", "simulation.end_time=0.25"});
    RunOptions options;
    options.quiet = true;
    options.outDir = dir.path();
    REQUIRE(runScene(scene, options).status == "ok");
    const double speed = summaryNumber(dir.path() + "/summary.json", "mean_crack_speed");
    const double distance =
        summaryNumber(dir.path() + "/summary.json", "crack_propagation_distance");
    INFO("steady crack speed " << speed << " m/s over " << distance << " m");
    REQUIRE(distance > 5.0);
    // validation.md V8 flat PST gate: 20-60 m/s (field: 20-30 m/s, Bergfeld et al. 2021;
    // 36 +- 6 to 49 +- 5 m/s, Bergfeld et al. 2022).
    REQUIRE(speed > 20.0);
    REQUIRE(speed < 60.0);
}
