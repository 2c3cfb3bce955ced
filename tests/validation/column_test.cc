// V7 (validation.md): the planar granular column collapse of Lube et al. (2005). A column L0 wide
// and a L0 tall against a slip wall collapses onto a sticky floor; its normalised runout
// (L - L0) / L0 follows 1.2 a for a < 1.8 and 1.9 a^(2/3) for a > 2.8. With a constant friction
// the runout is not converged (bench/studies.md, V7: it grows with every halving of dx, the
// thin front); with the mu(I) friction it converges, and the fitted parameters below put it
// within 15 % of the law at a = 0.5 to 4 (README, Validation: V7).
#include "test_util.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

using namespace firn;

namespace {

constexpr double kWidth = 0.1; // L0, m

/// bench/study.py's column_scene: 2D, APIC, 4 particles per cell, sand of 1500 kg/m^3, E 1 MPa,
/// nu 0.3, with mu(I) from 15 degrees at rest to 55 degrees, d 1 cm, I_0 0.279 (fitted to
/// Lube's law at dx 0.005, README V7), for end_time s.
std::unique_ptr<World> column(double aspect, double dx, double endTime) {
    std::string text =
        "[simulation]\nname = \"column\"\ndimension = 2\nend_time = " + std::to_string(endTime) +
        "\ngravity = [0.0, -9.81]\n";
    text += "[grid]\ndx = " + std::to_string(dx) + "\nparticles_per_cell = 4\n";
    text += "[[material]]\nname = \"sand\"\nmodel = \"granular\"\ndensity = 1500.0\n"
            "youngs_modulus = 1.0e6\npoisson_ratio = 0.3\nfriction_angle = 15.0\n"
            "dynamic_friction_angle = 55.0\ngrain_diameter = 0.01\n";
    text += "[[terrain]]\nshape = \"plane\"\npoint = [0.0, 0.0]\nnormal = [0.0, 1.0]\n"
            "boundary = \"sticky\"\n";
    text += "[[terrain]]\nshape = \"plane\"\npoint = [0.0, 0.0]\nnormal = [1.0, 0.0]\n"
            "boundary = \"slip\"\n";
    text += "[[body]]\nmaterial = \"sand\"\nshape = \"box\"\nmin = [0.0, 0.0]\nmax = [" +
            std::to_string(kWidth) + ", " + std::to_string(kWidth * aspect) + "]\n";
    return buildWorld(test::sceneFromText(text, "column"));
}

/// (L - L0) / L0 with L the 99th percentile of the particles' x (equal masses), as the study's
/// runout from the density volume (within half a cell).
double normalisedRunout(const World& world) {
    std::vector<float> x;
    x.reserve(world.particles.size());
    for (const Vec3f& p : world.particles.x) x.push_back(p[0]);
    const std::size_t k = std::size_t(0.99 * double(x.size() - 1));
    std::nth_element(x.begin(), x.begin() + long(k), x.end());
    return (double(x[k]) - kWidth) / kWidth;
}

double lubeLaw(double aspect) {
    return aspect < 1.8 ? 1.2 * aspect : 1.9 * std::pow(aspect, 2.0 / 3.0);
}

/// Collapses a column to rest (the study's end times: 0.6 s at a <= 1, 1.2 s at a = 4).
double collapse(double aspect, double dx) {
    const double endTime = 0.2 * std::ceil(3.0 * std::sqrt(std::max(1.0, aspect)) - 1e-9);
    auto world = column(aspect, dx, endTime);
    test::advanceTo(*world, endTime);
    return normalisedRunout(*world);
}

} // namespace

TEST_CASE("V7 column collapse with mu(I): the runout follows Lube's law at a = 0.5 and 4",
          "[validation][granular][column]") {
    // The 15 %, at the study's dx 0.005 (20 cells across the column). Measured with
    // the density volume (bench/study.py slice): -10.0 % at a = 0.5 and +9.0 % at a = 4; here,
    // from the particles, -10.2 % and +8.8 %. The experiments themselves spread 20-30 %
    // (validation.md).
    for (const double aspect : {0.5, 4.0}) {
        const double runout = collapse(aspect, 0.005);
        INFO("a = " << aspect << ": runout " << runout << ", law " << lubeLaw(aspect));
        CHECK(runout == Approx(lubeLaw(aspect)).epsilon(0.15));
    }
}

TEST_CASE("V7 column collapse with mu(I): the a = 1 runout converges with dx",
          "[validation][granular][column]") {
    // validation.md's gate: < 3 % from dx to dx/2. With a constant friction it grew by 28 %
    // from dx 0.01 to 0.005 (README); with mu(I) the study measured 1.227, 1.239 and 1.208 at
    // dx 0.01, 0.005 and 0.0025 (here, from the particles: 1.211 and 1.225, +1.1 %): the fast
    // thin front carries more friction, so it stops thinning with the grid.
    const double coarse = collapse(1.0, 0.01), fine = collapse(1.0, 0.005);
    INFO("runout " << coarse << " at dx 0.01, " << fine << " at dx 0.005, law 1.2");
    CHECK(fine == Approx(coarse).epsilon(0.03));
    CHECK(fine == Approx(lubeLaw(1.0)).epsilon(0.15));
}
