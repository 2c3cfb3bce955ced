// Voellmy's bed law (RAMMS): a slab sliding on a Voellmy bed reaches the speed where gravity's
// pull balances the basal friction, rho g h sin th = mu rho g h cos th + rho g u^2 / xi, so
// u_inf = sqrt(xi h (sin th - mu cos th)); from rest u(t) = u_inf tanh(t a / u_inf) with
// a = g (sin th - mu cos th) (the Coulomb block's acceleration).
#include "test_util.h"

#include <firn/diagnostics.h>

#include <catch2/catch.hpp>

#include <cmath>
#include <string>

using namespace firn;

namespace {

constexpr double kG = 9.81;
constexpr double kPi = 3.14159265358979323846;

std::unique_ptr<World> voellmySlab(double mu, double xi, double dx) {
    return test::slabOnTiltedBed("voellmy",
                                 "boundary = \"voellmy\"\nfriction = " + std::to_string(mu) +
                                     "\nturbulence = " + std::to_string(xi) + "\n",
                                 30.0, dx);
}

} // namespace

TEST_CASE("Voellmy bed: a slab reaches u = sqrt(xi h (sin th - mu cos th)) at two resolutions",
          "[validation][voellmy]") {
    const double th = 30.0 * kPi / 180.0, h = 1.0;
    for (const double mu : {0.0, 0.2}) {
        const double xi = 20.0; // m/s^2: small, so that u_inf is reached within 3 s
        const double a = kG * (std::sin(th) - mu * std::cos(th));
        const double uInf = std::sqrt(xi * h * (std::sin(th) - mu * std::cos(th)));
        for (const double dx : {0.1, 0.05}) {
            auto w = voellmySlab(mu, xi, dx);
            test::advanceTo(*w, 1.0);
            const double u1 = test::meanSpeedX(*w);
            test::advanceTo(*w, 3.0);
            const double u3 = test::meanSpeedX(*w);
            INFO("mu " << mu << ", dx " << dx << ": u(1 s) " << u1 << " (law "
                       << uInf * std::tanh(a / uInf) << "), u(3 s) " << u3 << " (u_inf " << uInf
                       << ")");
            // 3 % at 3 s (tanh within 0.1 % of 1 there): the drag acts on the bottom cell's
            // particles, a layer of dx whose mass the seeding resolves to a particle row.
            CHECK(u3 == Approx(uInf).epsilon(0.03));
            // On the way: the tanh law within 5 %, the slab's elastic start included.
            CHECK(u1 == Approx(uInf * std::tanh(a / uInf)).epsilon(0.05));
        }
    }
}
