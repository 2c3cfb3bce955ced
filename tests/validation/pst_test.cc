// validation.md V8: the Propagation Saw Test with the mixed-mode weak layer (scenes/pst.toml,
// at the CI spacing dx 0.03; a 3 m column where only onset matters). The cut is at the
// down-slope end, as in the field; a slope tilts gravity so that x runs down the slope.
#include "test_util.h"

#include <firn_test_paths.h>

#include <firn/diagnostics.h>
#include <firn/run.h>

#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>
#include <regex>
#include <sstream>

using namespace firn;

namespace {

const std::string kPst = std::string(FIRN_SOURCE_DIR) + "/scenes/pst.toml";
constexpr double kPi = 3.14159265358979323846;

std::string gravityFor(double slopeDeg) {
    const double psi = slopeDeg * kPi / 180.0;
    std::ostringstream g;
    g.precision(9);
    g << "simulation.gravity=[" << 9.81 * std::sin(psi) << ", " << -9.81 * std::cos(psi) << "]";
    return g.str();
}

/// The PST scene on a 3 m column at dx 0.03 with a cut of `cutLength` at its down-slope end,
/// run in-process for 0.2 s (the crack crosses 3 m in < 0.1 s when it runs). `saw` is the
/// cut's saw key ("quasi_static", the scene's default, or "instant").
FrameDiagnostics runShortColumn(double slopeDeg, double cutLength,
                                const std::string& saw = "quasi_static") {
    const SceneDesc scene = loadScene(
        kPst, {"grid.dx=0.03", gravityFor(slopeDeg), "body.weak.x_range=[0.0, 3.0]",
               "body.slab.x_range=[0.0, 3.0]", "cut.weak.from_x=" + std::to_string(3.0 - cutLength),
               "cut.weak.length=" + std::to_string(cutLength), "cut.weak.saw=\"" + saw + "\""});
    auto world = buildWorld(scene);
    test::advanceTo(*world, 0.2);
    return computeDiagnostics(*world);
}

/// True when the crack runs (nearly) to the up-slope end of the 3 m column.
bool propagates(double slopeDeg, double cutLength, const std::string& saw = "quasi_static") {
    const FrameDiagnostics d = runShortColumn(slopeDeg, cutLength, saw);
    return !std::isnan(d.crackMinX) && d.crackMinX < 0.1;
}

/// Critical cut length by bisection on [0, 0.8] m to 2.5 cm: {stays, runs}.
std::pair<double, double> criticalCut(double slopeDeg) {
    double stays = 0.0, runs = 0.8;
    for (int i = 0; i < 5; ++i) {
        const double mid = 0.5 * (stays + runs);
        (propagates(slopeDeg, mid) ? runs : stays) = mid;
    }
    return {stays, runs};
}

/// a_c of Gaume et al. (2017a), validation.md V8, for pst.toml's slab and weak layer.
double closedFormCut(double slopeDeg) {
    const double psi = slopeDeg * kPi / 180.0, rhoGD = 250.0 * 9.81 * 0.5;
    const double lambda = std::sqrt(5e6 / (1.0 - 0.04) * 0.5 * 0.06 / 0.2e6);
    const double sigmaN = rhoGD * std::cos(psi), tauG = rhoGD * std::sin(psi), tauP = 1000.0;
    return lambda * (-tauG + std::sqrt(tauG * tauG + 2.0 * sigmaN * (tauP - tauG))) / sigmaN;
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

/// Mean crack speed on the full 6 m column of scenes/pst.toml (its 0.8 m cut at the
/// down-slope end) at dx 0.03; `distance` gets how far the crack ran.
double crackSpeed(double slopeDeg, double& distance) {
    test::TempDir dir("firn-pst");
    const SceneDesc scene =
        loadScene(kPst, {"grid.dx=0.03", gravityFor(slopeDeg), "output.particles=false",
                         "output.volumes=[]", "simulation.end_time=0.25"});
    RunOptions options;
    options.quiet = true;
    options.outDir = dir.path();
    REQUIRE(runScene(scene, options).status == "ok");
    distance = summaryNumber(dir.path() + "/summary.json", "crack_propagation_distance");
    return summaryNumber(dir.path() + "/summary.json", "mean_crack_speed");
}

} // namespace

TEST_CASE("V8 PST: a short cut stays put, a long cut runs the column", "[validation][pst]") {
    // The crack is where weak-layer particles have started to soften (eta > 0).
    const FrameDiagnostics shortCut = runShortColumn(0.0, 0.1);
    const double reach = std::isnan(shortCut.crackMinX) ? 0.0 : 2.9 - shortCut.crackMinX;
    INFO("cut 0.1 m: crack reaches " << reach << " m past the cut");
    // Below critical the failure stays in the cut tip's neighbourhood: within 4 cells.
    REQUIRE(reach < 0.12);

    const FrameDiagnostics longCut = runShortColumn(0.0, 0.8);
    INFO("cut 0.8 m: crack from " << longCut.crackMinX << " to " << longCut.crackMaxX << " m");
    REQUIRE(longCut.crackMinX < 0.1);  // the whole 3 m column
    REQUIRE(longCut.crackMaxX > 2.15); // starting at the cut tip
}

TEST_CASE("V8 PST: an instant saw needs a shorter cut than the quasi-static one",
          "[validation][pst]") {
    // A field saw takes seconds to cut, the overhang's flexural response milliseconds: it takes
    // its load quasi-statically (the scenes' default saw). Removing the cut at once from the
    // settled column drops the overhang, whose dynamic overshoot of its bending load fails the
    // layer at a shorter cut: a_c 0.325-0.35 m instant against 0.50-0.525 m quasi-static
    // (dx 0.03, flat, README "Snow"). 0.42 m lies 0.07 m (3-4 particle spacings) from both.
    CHECK(propagates(0.0, 0.42, "instant"));
    CHECK_FALSE(propagates(0.0, 0.42, "quasi_static"));
}

TEST_CASE("V8 PST: the critical cut length is field-like and falls with slope",
          "[validation][pst]") {
    const auto flat = criticalCut(0.0);
    const auto steep = criticalCut(30.0);
    const double acFlat = 0.5 * (flat.first + flat.second);
    const double acSteep = 0.5 * (steep.first + steep.second);
    const double ratio = acSteep / acFlat, closedRatio = closedFormCut(30.0) / closedFormCut(0.0);
    INFO("a_c flat in [" << flat.first << ", " << flat.second << "] m, 30 deg in [" << steep.first
                         << ", " << steep.second << "] m: ratio " << ratio << " (closed form "
                         << closedRatio << ")");
    // validation.md V8: a_c within the field range 0.1-1 m on flat ground and falling with
    // slope (measured with the quasi-static saw 0.50-0.525 and 0.45-0.475 m, midpoints of 2.5 cm
    // brackets). V8's third gate, a_c(30)/a_c(0) within 30 % of the closed form's 0.355, is NOT
    // met (0.90; README "Snow"): it was met only while the floor's friction (0.5 < tan 30) let
    // the column slide.
    CHECK(acFlat > 0.1);
    CHECK(acFlat < 1.0);
    CHECK(acSteep < acFlat);
}

TEST_CASE("V8 PST: an uncut column stands on 35 deg", "[validation][pst]") {
    // Field PSTs stand uncut on 35-38 deg slopes; the weak layer is bonded to the old snow below
    // (its bed, Coulomb friction 1.0, holds). With the bed's former friction 0.5 (< tan 35) the
    // whole layer failed within 0.25 s from the column's down-slope end. A 1 cm cut is less than a
    // particle spacing (1.5 cm at dx 0.03); 0.4 s is twice the window of the bisection above.
    const SceneDesc scene = loadScene(
        kPst, {"grid.dx=0.03", gravityFor(35.0), "body.weak.x_range=[0.0, 3.0]",
               "body.slab.x_range=[0.0, 3.0]", "cut.weak.from_x=2.99", "cut.weak.length=0.01"});
    auto world = buildWorld(scene);
    test::advanceTo(*world, 0.4);
    const FrameDiagnostics d = computeDiagnostics(*world);
    INFO("crack from " << d.crackMinX << " to " << d.crackMaxX << " m");
    CHECK(std::isnan(d.crackMinX));
}

TEST_CASE("V8 PST: the steady crack speed is field-like on flat ground and faster on 30 deg",
          "[validation][pst]") {
    // The full 6 m column: a steady speed needs > 4-5 m of propagation (validation.md V8).
    double flatDistance = 0.0, steepDistance = 0.0;
    const double flat = crackSpeed(0.0, flatDistance);
    const double steep = crackSpeed(30.0, steepDistance);
    INFO("flat: " << flat << " m/s over " << flatDistance << " m; 30 deg: " << steep << " m/s over "
                  << steepDistance << " m");
    // The tracker counts the tip's travel where it advances faster than 10 m/s: 4.95 m of the
    // 5.2 flat; 4.35 m on 30 deg, where cracks nucleate ahead of the tip (1.9 m in one 5 ms
    // frame) and the tracked end switches between the crack's two ends (README "Snow").
    REQUIRE(flatDistance > 4.5);
    REQUIRE(steepDistance > 4.0);
    // validation.md V8 flat PST gate: 20-60 m/s (field: 20-30 m/s, Bergfeld et al. 2021;
    // 36 +- 6 to 49 +- 5 m/s, Bergfeld et al. 2022); on a slope the slab's weight drives the
    // crack too: faster than on flat ground.
    CHECK(flat > 20.0);
    CHECK(flat < 60.0);
    CHECK(steep > flat);
}
