// B-spline weights and the P2G/G2P transfers: conservation and exactness properties.
#include "test_util.h"

#include <firn/bspline.h>
#include <firn/transfer.h>

#include <Eigen/Geometry>
#include <catch2/catch.hpp>

#include <cmath>
#include <random>

using namespace firn;

namespace {

// A free elastic body without gravity or terrain; `shape` is a body table's shape lines.
std::unique_ptr<World> freeBody(int dim, const std::string& shape, const std::string& transfer) {
    const std::string vec0 = dim == 3 ? "[0.0, 0.0, 0.0]" : "[0.0, 0.0]";
    const std::string text = "[simulation]\nname = \"t\"\ndimension = " + std::to_string(dim) +
                             "\nend_time = 1.0\ngravity = " + vec0 +
                             "\n[grid]\ndx = 0.1\nparticles_per_cell = " + (dim == 3 ? "8" : "4") +
                             "\ntransfer = \"" + transfer +
                             "\"\ncfl = 0.3\n"
                             "[[material]]\nname = \"e\"\nmodel = \"elastic\"\ndensity = 100.0\n"
                             "youngs_modulus = 1.0e4\npoisson_ratio = 0.3\n"
                             "[[body]]\nmaterial = \"e\"\n" +
                             shape;
    return buildWorld(test::sceneFromText(text));
}

Eigen::Vector3d totalMomentum(const ParticleSet& ps) {
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < ps.size(); ++i) p += double(ps.mass[i]) * ps.v[i].cast<double>();
    return p;
}

// Angular momentum about the origin including the APIC affine part: for the affine field
// v + C (x - x_p) over a particle's mass with second moment D = dx^2/4 I (quadratic B-splines),
// L_affine = m D (C_zy - C_yz, C_xz - C_zx, C_yx - C_xy) (Jiang et al. 2015, sec. 5.3).
Eigen::Vector3d angularMomentum(const ParticleSet& ps) {
    const double d = 0.25 * double(ps.dx) * ps.dx;
    Eigen::Vector3d L = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < ps.size(); ++i) {
        const double m = ps.mass[i];
        const Eigen::Matrix3d C = ps.C[i].cast<double>();
        L += m * ps.x[i].cast<double>().cross(ps.v[i].cast<double>());
        L += m * d * Eigen::Vector3d(C(2, 1) - C(1, 2), C(0, 2) - C(2, 0), C(1, 0) - C(0, 1));
    }
    return L;
}

} // namespace

TEST_CASE("quadratic B-spline weights: partition of unity and linear reproduction", "[transfer]") {
    // Float arithmetic on O(1) weights: 1e-6 is a few ulps of the sum.
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-50.f, 50.f);
    for (int n = 0; n < 1000; ++n) {
        const float xs[3] = {u(rng), u(rng), u(rng)};
        QuadraticWeights q[3];
        for (int a = 0; a < 3; ++a) q[a] = quadraticWeights(xs[a]);
        for (int dim = 2; dim <= 3; ++dim) {
            double sum = 0, first[3] = {0, 0, 0};
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    for (int k = 0; k < (dim == 3 ? 3 : 1); ++k) {
                        const double w =
                            double(q[0].w[i]) * q[1].w[j] * (dim == 3 ? q[2].w[k] : 1.0);
                        sum += w;
                        first[0] += w * (q[0].base + i);
                        first[1] += w * (q[1].base + j);
                        first[2] += w * (q[2].base + k);
                    }
            REQUIRE(sum == Approx(1.0).margin(1e-6));
            for (int a = 0; a < dim; ++a) REQUIRE(first[a] == Approx(xs[a]).margin(1e-5));
        }
        for (int a = 0; a < 3; ++a) {
            REQUIRE(q[a].fx >= 0.5f);
            REQUIRE(q[a].fx < 1.5f + 1e-5f);
        }
    }
}

TEST_CASE("P2G conserves mass and linear momentum", "[transfer]") {
    for (int dim = 2; dim <= 3; ++dim) {
        const std::string shape =
            dim == 3 ? "shape = \"sphere\"\ncenter = [0.3, 0.2, -0.1]\nradius = 0.45\n"
                     : "shape = \"sphere\"\ncenter = [0.3, 0.2]\nradius = 0.45\n";
        for (const char* transfer : {"apic", "pic", "flip"}) {
            auto world = freeBody(dim, shape, transfer);
            ParticleSet& ps = world->particles;
            std::mt19937 rng(3);
            std::normal_distribution<float> n01;
            for (std::size_t i = 0; i < ps.size(); ++i) {
                ps.v[i] = Vec3f(n01(rng), n01(rng), dim == 3 ? n01(rng) : 0.f);
                for (int a = 0; a < dim; ++a)
                    for (int b = 0; b < dim; ++b) ps.C[i](a, b) = n01(rng);
                ps.tau[i] =
                    Sym3f{n01(rng), n01(rng), dim == 3 ? n01(rng) : 0.f, n01(rng), 0.f, 0.f};
            }
            world->grid.rebuild(ps, world->transfer == Transfer::Flip ? 3 : 0);
            const TransferParams params{dim, world->dx, 1e-3f, world->transfer, 0.95f};
            particlesToGrid(ps, world->grid, params, world->scratch);
            double gridMass = 0, particleMass = 0;
            Eigen::Vector3d gridMomentum = Eigen::Vector3d::Zero();
            for (std::size_t b = 0; b < world->grid.blockCount(); ++b)
                for (int n = 0; n < kLeafNodes; ++n) {
                    gridMass += world->grid.mass(b)[n];
                    for (int c = 0; c < 3; ++c) {
                        gridMomentum[c] += world->grid.velocity(b)[3 * n + c];
                        // the stress impulse (FLIP keeps it apart) sums to zero as well
                        if (world->transfer == Transfer::Flip)
                            gridMomentum[c] += world->grid.aux(b)[3 * n + c];
                    }
                }
            for (float m : ps.mass) particleMass += m;
            const Eigen::Vector3d p = totalMomentum(ps);
            // Float sums over a few thousand terms: relative 1e-5 of the magnitudes involved.
            REQUIRE(gridMass == Approx(particleMass).epsilon(1e-5));
            const double scale = particleMass * 3.0;
            for (int c = 0; c < 3; ++c) REQUIRE(std::abs(gridMomentum[c] - p[c]) < 1e-5 * scale);
        }
    }
}

TEST_CASE("APIC transfers an affine velocity field exactly", "[transfer]") {
    for (int dim = 2; dim <= 3; ++dim) {
        const std::string shape =
            dim == 3 ? "shape = \"box\"\nmin = [-0.33, 0.1, 0.2]\nmax = [0.51, 0.77, 0.95]\n"
                     : "shape = \"box\"\nmin = [-0.33, 0.1]\nmax = [0.51, 0.77]\n";
        auto world = freeBody(dim, shape, "apic");
        ParticleSet& ps = world->particles;
        Mat3f A = Mat3f::Zero();
        A.topLeftCorner(dim, dim) = Eigen::Matrix3f::Random().topLeftCorner(dim, dim);
        const Vec3f b(0.5f, -1.f, dim == 3 ? 0.25f : 0.f);
        for (std::size_t i = 0; i < ps.size(); ++i) ps.v[i] = A * ps.x[i] + b, ps.C[i] = A;
        world->grid.rebuild(ps, 0);
        const TransferParams p2gParams{dim, world->dx, 1e-3f, Transfer::Apic, 0.f};
        particlesToGrid(ps, world->grid, p2gParams, world->scratch);
        updateGridVelocity(*world, 1e-3f); // no gravity, no terrain: v = p / m
        const TransferParams g2pParams{dim, world->dx, 0.f, Transfer::Apic, 0.f};
        gridToParticles(ps, world->grid, g2pParams);
        // Exact in real arithmetic; float rounding of O(1) values over 27 nodes: 1e-5.
        for (std::size_t i = 0; i < ps.size(); ++i) {
            const Vec3f expect = A * ps.x[i] + b;
            REQUIRE((ps.v[i] - expect).norm() < 1e-5f * (1.f + expect.norm()));
            REQUIRE((ps.C[i] - A).norm() < 1e-4f * (1.f + A.norm()));
        }
    }
}

TEST_CASE("APIC conserves the angular momentum of a spinning free body, PIC loses it",
          "[transfer]") {
    for (int dim = 2; dim <= 3; ++dim) {
        const std::string shape =
            dim == 3 ? "shape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 0.4\n"
                     : "shape = \"sphere\"\ncenter = [0.0, 0.0]\nradius = 0.4\n";
        double lostFraction[2] = {0, 0};
        int t = 0;
        for (const char* transfer : {"apic", "pic"}) {
            auto world = freeBody(dim, shape, transfer);
            ParticleSet& ps = world->particles;
            const float omega = 2.f; // rad/s about z: rim speed 0.8 m/s
            for (std::size_t i = 0; i < ps.size(); ++i) {
                ps.v[i] = Vec3f(-omega * ps.x[i][1], omega * ps.x[i][0], 0.f);
                ps.C[i] = Mat3f::Zero();
                ps.C[i](0, 1) = -omega, ps.C[i](1, 0) = omega;
            }
            const double L0 = angularMomentum(ps)[2];
            test::advanceTo(*world, 0.5);
            REQUIRE(world->steps > 50);
            lostFraction[t++] = (L0 - angularMomentum(ps)[2]) / L0;
        }
        INFO("dim " << dim << ": APIC |dL/L| = " << lostFraction[0] << ", PIC " << lostFraction[1]);
        // validation.md V5: |dL/L| < 1e-6 in float. The sums run in double over float state;
        // what remains is float rounding of positions and velocities per step.
        REQUIRE(std::abs(lostFraction[0]) < 1e-5);
        // PIC damps the rotation (its dissipation of the affine mode is the known failure).
        REQUIRE(lostFraction[1] > 1e-2);
    }
}

TEST_CASE("FLIP with a relaxation time damps particle-velocity noise per second, not per step",
          "[transfer]") {
    // A free body at rest whose particles carry a checkerboard velocity (+-0.1 m/s along x at
    // the dx/2 seeding pitch): noise that the grid barely sees (each node sums both signs).
    // FLIP keeps it; a fixed blend b removes a share 1 - b of it per step, so the damping
    // follows the number of steps; flip_relaxation_time tau removes it as exp(-t / tau).
    const auto remainingEnergy = [](double flipBlend, double relaxationTime, double dt) {
        auto world = freeBody(2, "shape = \"box\"\nmin = [0.0, 0.0]\nmax = [0.8, 0.8]\n", "flip");
        world->flipBlend = float(flipBlend);
        world->flipRelaxationTime = float(relaxationTime);
        ParticleSet& ps = world->particles;
        const auto energy = [&ps] {
            double e = 0;
            for (std::size_t i = 0; i < ps.size(); ++i)
                e += 0.5 * ps.mass[i] * ps.v[i].squaredNorm();
            return e;
        };
        for (std::size_t i = 0; i < ps.size(); ++i) {
            const int cx = int(std::floor(ps.x[i][0] / (0.5f * ps.dx)));
            const int cy = int(std::floor(ps.x[i][1] / (0.5f * ps.dx)));
            ps.v[i] = Vec3f((cx + cy) % 2 ? 0.1f : -0.1f, 0.f, 0.f);
        }
        const double e0 = energy();
        for (int n = 0; n < int(std::lround(0.2 / dt)); ++n) step(*world, dt);
        return energy() / e0;
    };
    const double tau = 0.1; // s: 0.2 s is two relaxation times
    const double relaxedFine = remainingEnergy(1.0, tau, 2e-4);
    const double relaxedCoarse = remainingEnergy(1.0, tau, 1e-3);
    const double blendFine = remainingEnergy(0.99, 0.0, 2e-4);
    const double blendCoarse = remainingEnergy(0.99, 0.0, 1e-3);
    const double pure = remainingEnergy(1.0, 0.0, 1e-3);
    INFO("kinetic energy left after 0.2 s: tau 0.1 s at dt 2e-4 / 1e-3: "
         << relaxedFine << " / " << relaxedCoarse << "; blend 0.99: " << blendFine << " / "
         << blendCoarse << "; pure FLIP " << pure);
    // The noise's energy falls as exp(-2 t / tau) = e^-4 at either time step (measured 0.0184
    // and 0.0174; 10 %: the grid keeps a few % of the checkerboard, which does not relax).
    CHECK(relaxedFine == Approx(std::exp(-4.0)).epsilon(0.1));
    CHECK(relaxedCoarse == Approx(std::exp(-4.0)).epsilon(0.1));
    // Pure FLIP keeps it (measured 0.94); the fixed blend's damping follows the step count
    // (0.99^(2 n): measured 2e-9 against 0.017 with five times the steps).
    CHECK(pure > 0.9);
    CHECK(blendFine < 0.1 * blendCoarse);
}

namespace {

// One transfer without forces (no gravity, stress-free particles, dt 0 in G2P) with `transfer`
// of order `order`: the particle velocities that the transfer alone makes of the present ones.
void transferOnce(World& world, Transfer transfer, int order) {
    world.transfer = transfer;
    world.xpicOrder = order;
    ParticleSet& ps = world.particles;
    world.grid.rebuild(ps, keepsReference(transfer) ? 3 : 0);
    const TransferParams params{world.dim, world.dx, 0.f, transfer, 1.f, -1, order};
    particlesToGrid(ps, world.grid, params, world.scratch);
    if (transfer == Transfer::Xpic) xpicProjection(ps, world.grid, params, world.scratch);
    updateGridVelocity(world, 0.f);
    if (transfer == Transfer::Xpic) subtractXpicProjection(world.grid, world.scratch);
    gridToParticles(ps, world.grid, params);
}

double kineticEnergy(const ParticleSet& ps) {
    double e = 0;
    for (std::size_t i = 0; i < ps.size(); ++i) e += 0.5 * ps.mass[i] * ps.v[i].squaredNorm();
    return e;
}

} // namespace

TEST_CASE("XPIC of order 1 is PIC", "[transfer]") {
    for (int dim = 2; dim <= 3; ++dim) {
        const std::string shape =
            dim == 3 ? "shape = \"sphere\"\ncenter = [0.3, 0.2, -0.1]\nradius = 0.45\n"
                     : "shape = \"sphere\"\ncenter = [0.3, 0.2]\nradius = 0.45\n";
        std::vector<Vec3f> velocities[2];
        int t = 0;
        for (const char* transfer : {"pic", "xpic"}) {
            auto world = freeBody(dim, shape, transfer);
            world->xpicOrder = 1;
            ParticleSet& ps = world->particles;
            std::mt19937 rng(5);
            std::normal_distribution<float> n01;
            for (std::size_t i = 0; i < ps.size(); ++i)
                ps.v[i] = Vec3f(n01(rng), n01(rng), dim == 3 ? n01(rng) : 0.f);
            for (int n = 0; n < 20; ++n) step(*world, 1e-3);
            velocities[t++] = ps.v;
        }
        // PIC adds the stress impulse to the momentum before dividing by the mass, XPIC(1) after:
        // float rounding of O(1) velocities over 20 steps, 1e-5.
        REQUIRE(velocities[0].size() == velocities[1].size());
        for (std::size_t i = 0; i < velocities[0].size(); ++i)
            REQUIRE((velocities[1][i] - velocities[0][i]).norm() <
                    1e-5f * (1.f + velocities[0][i].norm()));
    }
}

TEST_CASE("XPIC(m) keeps what the grid can carry as m grows and drops FLIP's noise as PIC does",
          "[transfer]") {
    for (int dim = 2; dim <= 3; ++dim) {
        const std::string shape =
            dim == 3 ? "shape = \"box\"\nmin = [0.0, 0.0, 0.0]\nmax = [0.8, 0.6, 0.4]\n"
                     : "shape = \"box\"\nmin = [0.0, 0.0]\nmax = [0.8, 0.8]\n";
        auto world = freeBody(dim, shape, "pic");
        ParticleSet& ps = world->particles;
        // A velocity field that the grid carries: random particle velocities through one PIC
        // transfer, v = S S+ v_random, in the range of S.
        std::mt19937 rng(11);
        std::normal_distribution<float> n01;
        for (std::size_t i = 0; i < ps.size(); ++i)
            ps.v[i] = Vec3f(n01(rng), n01(rng), dim == 3 ? n01(rng) : 0.f);
        transferOnce(*world, Transfer::Pic, 1);
        const std::vector<Vec3f> carried = ps.v;
        const auto lostFraction = [&](Transfer transfer, int order) {
            ps.v = carried;
            transferOnce(*world, transfer, order);
            double lost = 0, total = 0;
            for (std::size_t i = 0; i < ps.size(); ++i) {
                lost += ps.mass[i] * (ps.v[i] - carried[i]).squaredNorm();
                total += ps.mass[i] * carried[i].squaredNorm();
            }
            return std::sqrt(lost / total);
        };
        std::vector<double> lost;
        for (int order : {1, 2, 4, 8}) lost.push_back(lostFraction(Transfer::Xpic, order));
        const double flip = lostFraction(Transfer::Flip, 1);
        INFO("dim " << dim
                    << ": relative change of a carried field by XPIC(1, 2, 4, 8): " << lost[0]
                    << ", " << lost[1] << ", " << lost[2] << ", " << lost[3] << "; FLIP " << flip);
        // PIC smooths the carried field (S S+ is not a projection); each order removes more of
        // that error (measured 0.44, 0.29, 0.16, 0.077 in 2D, 0.48, 0.33, 0.20, 0.11 in 3D: a
        // factor 0.5-0.7 an order doubling, 0.8 leaves a margin), and FLIP keeps the field to
        // float rounding.
        CHECK(lost[0] > 0.1);
        for (int k = 1; k < 4; ++k) CHECK(lost[k] < 0.8 * lost[k - 1]);
        CHECK(flip < 1e-5);

        // Noise the grid does not carry: a checkerboard at the dx/2 seeding pitch. FLIP keeps
        // it, XPIC removes it as PIC does (S+ of it is small, so every term of v* is).
        const auto noiseLeft = [&](Transfer transfer, int order) {
            for (std::size_t i = 0; i < ps.size(); ++i) {
                int parity = 0;
                for (int a = 0; a < dim; ++a)
                    parity += int(std::floor(ps.x[i][a] / (0.5f * ps.dx)));
                ps.v[i] = Vec3f(parity % 2 ? 0.1f : -0.1f, 0.f, 0.f);
            }
            const double e0 = kineticEnergy(ps);
            transferOnce(*world, transfer, order);
            return kineticEnergy(ps) / e0;
        };
        const double noisePic = noiseLeft(Transfer::Pic, 1);
        const double noiseXpic = noiseLeft(Transfer::Xpic, 8);
        const double noiseFlip = noiseLeft(Transfer::Flip, 1);
        INFO("checkerboard energy left: PIC " << noisePic << ", XPIC(8) " << noiseXpic << ", FLIP "
                                              << noiseFlip);
        // Measured: PIC 9e-4 / 2.5e-4, XPIC(8) 7e-3 / 3.4e-3 (2D / 3D), FLIP 1.
        CHECK(noiseFlip > 0.99);
        CHECK(noiseXpic < 0.02);
    }
}

TEST_CASE("G2P's squared-speed bound flags exactly the speeds above kMovedSpeed", "[transfer]") {
    // Every float within 4 096 ulps of the bound, each side: the root of those above it exceeds
    // kMovedSpeed, of the others not (so a flag set from squares is the flag set from speeds).
    const float bound = movedSpeedSquaredBound();
    float s = bound;
    for (int k = 0; k < 4096; ++k) s = std::nextafter(s, 0.f);
    int above = 0;
    for (int k = 0; k < 8193; ++k, s = std::nextafter(s, 1.f)) {
        REQUIRE((std::sqrt(s) > kMovedSpeed) == (s > bound));
        above += s > bound;
    }
    REQUIRE(above == 4096);
}
