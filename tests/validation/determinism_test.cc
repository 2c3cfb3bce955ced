// Same scene, same seed: bitwise the same state and metrics for 1 and 2 threads.
#include "test_util.h"

#include <firn/run.h>

#include <catch2/catch.hpp>
#include <tbb/global_control.h>

#include <cstring>
#include <fstream>
#include <sstream>

using namespace firn;

namespace {

const char* kScene = R"(
[simulation]
name = "determinism"
dimension = 3
end_time = 0.1
frame_rate = 50
seed = 11

[grid]
dx = 0.05
particles_per_cell = 8
transfer = "%TRANSFER%"

[[material]]
name = "sand"
model = "granular"
density = 1500.0
youngs_modulus = 1.0e6
poisson_ratio = 0.3
friction_angle = 30.0

[[terrain]]
shape = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.3, 1.0, 0.0]
%BOUNDARY%

[[body]]
material = "sand"
shape = "sphere"
center = [0.0, 0.32, 0.0]
radius = 0.3
velocity = [1.0, -0.5, 0.2]
)";

/// `sticky`: the ground holds the sand, its inside nodes mirrored (firn/sticky_walls.h: a serial
/// fold over the ghost nodes, in block order); else Coulomb friction 0.3.
std::string sceneText(const std::string& transfer, bool sticky = false) {
    std::string s = kScene;
    s.replace(s.find("%TRANSFER%"), 10, transfer);
    s.replace(s.find("%BOUNDARY%"), 10,
              sticky ? "boundary = \"sticky\"" : "boundary = \"friction\"\nfriction = 0.3");
    return s;
}

template <typename T> bool sameBits(const std::vector<T>& a, const std::vector<T>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

std::unique_ptr<World> runWithThreads(const SceneDesc& scene, int threads) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    auto world = buildWorld(scene);
    test::advanceTo(*world, 0.1);
    return world;
}

/// metrics.csv without the wall_seconds column, the one thing allowed to differ.
std::string metricsWithoutWallClock(const std::string& path) {
    std::ifstream in(path);
    std::string line, out;
    int wallColumn = -1;
    while (std::getline(in, line)) {
        std::stringstream ss(line);
        std::string cell;
        for (int c = 0; std::getline(ss, cell, ','); ++c) {
            if (cell == "wall_seconds") wallColumn = c;
            if (c != wallColumn) out += cell + ",";
        }
        out += "\n";
    }
    return out;
}

} // namespace

TEST_CASE("the state after 0.1 s is bitwise the same for 1 and 2 threads", "[determinism]") {
    struct Case {
        const char* transfer;
        bool sticky;
    };
    for (const Case c : {Case{"apic", false}, Case{"flip", false}, Case{"apic", true},
                         Case{"flip", true}, Case{"xpic", true}}) {
        const SceneDesc scene = test::sceneFromText(sceneText(c.transfer, c.sticky), "determinism");
        auto one = runWithThreads(scene, 1);
        auto two = runWithThreads(scene, 2);
        INFO(c.transfer << (c.sticky ? ", sticky" : ", friction") << ": " << one->particles.size()
                        << " particles, " << one->steps << " steps");
        REQUIRE(one->steps == two->steps);
        REQUIRE(one->steps > 20);
        REQUIRE(one->particles.size() > 5000); // several leaves, so both threads get work
        REQUIRE(sameBits(one->particles.x, two->particles.x));
        REQUIRE(sameBits(one->particles.v, two->particles.v));
        REQUIRE(sameBits(one->particles.C, two->particles.C));
        REQUIRE(sameBits(one->particles.H, two->particles.H));
        REQUIRE(sameBits(one->particles.plastic, two->particles.plastic));
        // and the run did something: the sphere moved and the sand yielded
        double travelled = 0;
        for (const Vec3f& p : one->particles.x) travelled += p[0];
        REQUIRE(travelled / one->particles.size() > 0.05);
    }
}

TEST_CASE("metrics.csv is the same for 1 and 2 threads", "[determinism]") {
    const SceneDesc scene = test::sceneFromText(sceneText("apic"), "determinism");
    test::TempDir dir("firn-determinism");
    RunOptions options;
    options.quiet = true;
    options.threads = 1;
    options.outDir = dir.path() + "/one";
    REQUIRE(runScene(scene, options).status == "ok");
    options.threads = 2;
    options.outDir = dir.path() + "/two";
    REQUIRE(runScene(scene, options).status == "ok");
    const std::string a = metricsWithoutWallClock(dir.path() + "/one/metrics.csv");
    const std::string b = metricsWithoutWallClock(dir.path() + "/two/metrics.csv");
    REQUIRE(a.size() > 100);
    REQUIRE(a == b);
}
