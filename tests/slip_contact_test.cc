// The slip surface (firn/slip_contact.h): contact at one node, a block sliding across the
// surface (validation.md V1 with the bed on the grid), a bonded block that holds, scene errors.
#include "test_util.h"

#include <firn/slip_contact.h>

#include <Eigen/Dense>

#include <catch2/catch.hpp>

#include <cmath>

using namespace firn;

namespace {

constexpr double kG = 9.81;
constexpr double kPi = 3.14159265358979323846;

Vec3f momentum(float m0, const Vec3f& v0, float m1, const Vec3f& v1) {
    return m0 * v0 + m1 * v1;
}

/// A block sliding on an elastic bed under gravity tilted by theta, a flat sticky floor under the
/// bed: the block above the slip surface (slides_on), the bed below. `onWeakLayer`: the block
/// rests on the (strong, intact) weak layer instead of the bed, so the two are bonded.
std::unique_ptr<World> blockOnBed(double thetaDeg, double friction, bool onWeakLayer) {
    const double th = thetaDeg * kPi / 180;
    std::string text = "[simulation]\nname = \"slip\"\ndimension = 2\nend_time = 1.0\n"
                       "gravity_ramp = 0.1\ngravity = [" +
                       std::to_string(kG * std::sin(th)) + ", " +
                       std::to_string(-kG * std::cos(th)) + "]\n";
    text += "[grid]\ndx = 0.05\nparticles_per_cell = 4\ncfl = 0.4\n";
    text += "[[material]]\nname = \"stiff\"\nmodel = \"elastic\"\ndensity = 1000.0\n"
            "youngs_modulus = 1.0e7\npoisson_ratio = 0.3\n";
    // A weak layer far too strong to fail here: it only marks where the fields are bonded.
    text += "[[material]]\nname = \"weak\"\nmodel = \"weak_layer\"\ndensity = 1000.0\n"
            "youngs_modulus = 1.0e7\npoisson_ratio = 0.3\ninitial_p0 = 1.0e7\n";
    text += "[[terrain]]\nshape = \"plane\"\npoint = [0.0, 0.0]\nnormal = [0.0, 1.0]\n"
            "boundary = \"sticky\"\n";
    text += "[[body]]\nname = \"bed\"\nmaterial = \"stiff\"\nshape = \"box\"\n"
            "min = [0.0, 0.0]\nmax = [4.0, 0.25]\n";
    text += std::string("[[body]]\nname = \"weak\"\nmaterial = \"weak\"\nshape = \"box\"\n") +
            (onWeakLayer ? "min = [0.0, 0.25]\nmax = [1.5, 0.35]\n"
                         : "min = [3.5, 0.25]\nmax = [4.0, 0.35]\n");
    text += std::string("[[body]]\nname = \"block\"\nmaterial = \"stiff\"\nshape = \"box\"\n") +
            (onWeakLayer ? "min = [0.0, 0.35]\nmax = [1.0, 0.6]\n"
                         : "min = [0.0, 0.25]\nmax = [1.0, 0.5]\n") +
            "slides_on = \"weak\"\nslip_friction = " + std::to_string(friction) + "\n";
    return buildWorld(test::sceneFromText(text, "slip"));
}

/// x of the centre of mass of the upper field's particles (the block), m.
double blockX(const World& world) {
    double mx = 0, m = 0;
    const ParticleSet& ps = world.particles;
    for (std::size_t i = 0; i < ps.size(); ++i) {
        if (!(ps.plastic[i].flags & kFlagUpperField)) continue;
        mx += double(ps.mass[i]) * ps.x[i][0];
        m += ps.mass[i];
    }
    return mx / m;
}

/// Fitted acceleration of the block's centre of mass over [0.2, 1] s, m/s^2.
double blockAcceleration(World& world) {
    std::vector<double> t, s;
    test::advanceTo(world, 0.1);
    const double x0 = blockX(world);
    for (int k = 4; k <= 20; ++k) {
        test::advanceTo(world, 0.05 * k);
        t.push_back(world.time);
        s.push_back(blockX(world) - x0);
    }
    return test::fitAcceleration(t, s);
}

std::string errorOf(const std::string& text) {
    try {
        parseScene(text, "tests/slip.toml");
    } catch (const SceneError& e) {
        return e.what();
    }
    return "no error";
}

} // namespace

TEST_CASE("slip contact at a node: bonded, separating, sticking, sliding", "[slip]") {
    const Vec3f n(0.f, 1.f, 0.f);
    const float m0 = 2.f, m1 = 1.f;
    SECTION("bonded fields take the centre-of-mass velocity") {
        const Vec3f v0(0.f, 0.f, 0.f), v1(3.f, 3.f, 0.f);
        const FieldVelocities r = resolveSlipContact(m0, v0, m1, v1, n, 0.f, true);
        CHECK(r.lower.isApprox(Vec3f(1.f, 1.f, 0.f)));
        CHECK(r.upper.isApprox(Vec3f(1.f, 1.f, 0.f)));
    }
    SECTION("separating fields move freely") {
        const Vec3f v0(0.f, -1.f, 0.f), v1(2.f, 1.f, 0.f);
        const FieldVelocities r = resolveSlipContact(m0, v0, m1, v1, n, 10.f, false);
        CHECK(r.lower == v0);
        CHECK(r.upper == v1);
    }
    SECTION("approaching with enough friction: they stick") {
        // Relative to the centre of mass (0.5, -1): the upper field at (1, -2) * 2/3 ... its
        // tangential part 1.0 against a normal part 2.0 times friction 0.6 = 1.2: stick.
        const Vec3f v0(0.f, 0.f, 0.f), v1(1.5f, -3.f, 0.f);
        const FieldVelocities r = resolveSlipContact(m0, v0, m1, v1, n, 0.6f, false);
        const Vec3f centre = momentum(m0, v0, m1, v1) / (m0 + m1);
        CHECK(r.lower.isApprox(centre));
        CHECK(r.upper.isApprox(centre));
    }
    SECTION("approaching with little friction: the slip is reduced by friction times the normal "
            "velocity") {
        const Vec3f v0(0.f, 0.f, 0.f), v1(3.f, -3.f, 0.f);
        const float mu = 0.25f;
        const FieldVelocities r = resolveSlipContact(m0, v0, m1, v1, n, mu, false);
        const Vec3f centre = momentum(m0, v0, m1, v1) / (m0 + m1); // (1, -1)
        // Upper relative velocity (2, -2): normal part removed, tangential 2 - 0.25 * 2 = 1.5.
        CHECK(r.upper.isApprox(centre + Vec3f(1.5f, 0.f, 0.f)));
        CHECK(r.upper[1] == Approx(r.lower[1])); // no interpenetration along the normal
        CHECK(momentum(m0, r.lower, m1, r.upper).isApprox(momentum(m0, v0, m1, v1)));
    }
    SECTION("friction is isotropic in the tangent plane (3D)") {
        const Vec3f v0(0.f, 0.f, 0.f), v1(3.f, -3.f, 4.f);
        const FieldVelocities r = resolveSlipContact(1.f, v0, 1.f, v1, n, 0.1f, false);
        const Vec3f slip = r.upper - r.lower;
        CHECK(slip[1] == Approx(0.f).margin(1e-6));
        CHECK(slip[2] / slip[0] == Approx(4.f / 3.f)); // direction kept
        CHECK(momentum(1.f, r.lower, 1.f, r.upper).isApprox(v1));
    }
    CHECK(slipFrictionOfWeakLayer(1.2f) == Approx(0.6928f).epsilon(1e-4));
}

TEST_CASE("V1 across a slip surface: a block slides on a bed on the grid with a = g (sin th - mu "
          "cos th)",
          "[slip][validation]") {
    // 30 deg, mu 0.3: 9.81 (0.5 - 0.3 cos 30) = 2.3563 m/s^2. validation.md V1 allows 3 % and
    // says 1 % is achievable; we measure 0.03 % on the bed and hold the 1 % line. On the weak
    // layer marked collapsed (as the return mapping marks it, kFlagCollapsed) the nodes under
    // the block release the bond and it slides the same.
    const double expected = kG * (std::sin(kPi / 6) - 0.3 * std::cos(kPi / 6));
    for (const bool onCollapsedLayer : {false, true}) {
        auto world = blockOnBed(30, 0.3, onCollapsedLayer);
        if (onCollapsedLayer)
            for (std::size_t i = 0; i < world->particles.size(); ++i)
                if (world->particles.material[i] == world->slipMaterial)
                    world->particles.plastic[i].flags |= kFlagCollapsed;
        const double a = blockAcceleration(*world);
        INFO((onCollapsedLayer ? "on the collapsed layer" : "on the bed")
             << ": a = " << a << " m/s^2, expected " << expected);
        CHECK(a == Approx(expected).epsilon(0.01));
    }
}

TEST_CASE("V1 across a slip surface: a block sticks when tan th <= mu, and holds while bonded",
          "[slip][validation]") {
    // Friction 0.7 > tan 30 = 0.577: it sticks. Friction 0 on an intact weak layer: bonded, it
    // holds as one body would. validation.md V1: < 1e-3 dx of creep after 1 s.
    for (const bool bonded : {false, true}) {
        auto world = blockOnBed(30, bonded ? 0.0 : 0.7, bonded);
        test::advanceTo(*world, 0.1);
        const double x0 = blockX(*world);
        test::advanceTo(*world, 1.0);
        const double creep = blockX(*world) - x0;
        INFO((bonded ? "bonded, friction 0" : "friction 0.7") << ": creep " << creep << " m");
        CHECK(std::abs(creep) < 1e-3 * 0.05);
    }
}

TEST_CASE("slides_on and slip_friction: scene errors", "[slip][scene]") {
    const std::string head = "[simulation]\nname = \"s\"\ndimension = 2\nend_time = 1.0\n"
                             "[grid]\ndx = 0.1\n"
                             "[[material]]\nname = \"snow\"\nmodel = \"snow\"\ndensity = 250.0\n"
                             "[[material]]\nname = \"wl\"\nmodel = \"weak_layer\"\n"
                             "density = 100.0\n"
                             "[[body]]\nname = \"base\"\nmaterial = \"snow\"\nshape = \"box\"\n"
                             "min = [0.0, 0.0]\nmax = [1.0, 0.2]\n"
                             "[[body]]\nname = \"weak\"\nmaterial = \"wl\"\nshape = \"box\"\n"
                             "min = [0.0, 0.2]\nmax = [1.0, 0.3]\n";
    const std::string slab = "[[body]]\nname = \"slab\"\nmaterial = \"snow\"\nshape = \"box\"\n"
                             "min = [0.0, 0.3]\nmax = [1.0, 0.6]\n";
    CHECK(errorOf(head + slab + "slides_on = \"weak\"\n") == "no error");
    CHECK(errorOf(head + slab + "slides_on = \"base\"\n") ==
          "tests/slip.toml:33:13: error: body \"slab\": slides_on \"base\" is not an earlier "
          "body of a weak_layer material (such bodies: weak)");
    CHECK(errorOf(head + slab + "slip_friction = 0.5\n") ==
          "tests/slip.toml:33:17: error: body \"slab\": slip_friction: needs slides_on");
    CHECK(errorOf(head + slab + "slides_on = \"weak\"\nslip_friction = -0.5\n")
              .find("slip_friction: must be >= 0") != std::string::npos);
}
