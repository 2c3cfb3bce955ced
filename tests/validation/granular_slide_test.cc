// A granular mass sliding on an incline (tilted gravity on a Coulomb floor): with bed friction
// delta <= phi the centre of mass accelerates at g (sin th - tan delta cos th), the V1 law, since
// only the bed force acts on the mass as a whole.
#include "test_util.h"

#include <firn/diagnostics.h>

#include <Eigen/Dense>

#include <catch2/catch.hpp>

#include <cmath>
#include <string>
#include <vector>

using namespace firn;

namespace {

constexpr double kG = 9.81;
constexpr double kPi = 3.14159265358979323846;

/// A 1 m x 0.2 m layer of granular material (phi, E 10 MPa, rho 1500) on a flat floor with
/// Coulomb friction tan(delta), gravity tilted by theta and ramped over 0.1 s so the layer settles
/// without bouncing (as V1). 2D: the plane-strain section of a long mass.
std::unique_ptr<World> granularSlide(double thetaDeg, double deltaDeg, double phiDeg, double dx) {
    const double th = thetaDeg * kPi / 180;
    std::string text = "[simulation]\nname = \"granular-slide\"\ndimension = 2\nend_time = 1.0\n"
                       "gravity_ramp = 0.1\ngravity = [" +
                       std::to_string(kG * std::sin(th)) + ", " +
                       std::to_string(-kG * std::cos(th)) + "]\n";
    text += "[[terrain]]\nshape = \"plane\"\npoint = [0.0, 0.0]\nnormal = [0.0, 1.0]\n"
            "boundary = \"friction\"\nfriction = " +
            std::to_string(std::tan(deltaDeg * kPi / 180)) + "\n";
    text += "[[material]]\nname = \"sand\"\nmodel = \"granular\"\ndensity = 1500.0\n"
            "youngs_modulus = 1.0e7\npoisson_ratio = 0.3\nfriction_angle = " +
            std::to_string(phiDeg) + "\n";
    text += "[[body]]\nmaterial = \"sand\"\nshape = \"box\"\nmin = [0.0, 0.0]\nmax = [1.0, 0.2]\n";
    text += "[grid]\ndx = " + std::to_string(dx) + "\nparticles_per_cell = 4\ncfl = 0.4\n";
    return buildWorld(test::sceneFromText(text, "granular-slide"));
}

} // namespace

TEST_CASE("A granular mass slides with a = g (sin th - tan delta cos th) at two resolutions",
          "[validation][granular]") {
    struct Case {
        double thetaDeg, deltaDeg, phiDeg;
    };
    // th < phi: the mass slides on its bed as a block (its free ends slump a little).
    for (const Case c : {Case{25, 10, 30}, Case{35, 25, 40}})
        for (const double dx : {0.05, 0.025}) {
            auto world = granularSlide(c.thetaDeg, c.deltaDeg, c.phiDeg, dx);
            test::advanceTo(*world, 0.2);
            const Eigen::Vector3d c0 = computeDiagnostics(*world).centreOfMass;
            std::vector<double> t, s;
            for (int k = 4; k <= 20; ++k) { // every 0.05 s over [0.2, 1] s
                test::advanceTo(*world, 0.05 * k);
                t.push_back(world->time);
                s.push_back(computeDiagnostics(*world).centreOfMass[0] - c0[0]);
            }
            const double th = c.thetaDeg * kPi / 180, delta = c.deltaDeg * kPi / 180;
            const double expected = kG * (std::sin(th) - std::tan(delta) * std::cos(th));
            const double a = test::fitAcceleration(t, s);
            INFO("theta " << c.thetaDeg << " delta " << c.deltaDeg << " phi " << c.phiDeg << " dx "
                          << dx << ": a = " << a << ", expected " << expected);
            // The 2 %: V1's law for the mass as a whole.
            REQUIRE(a == Approx(expected).epsilon(0.02));
        }
}
