// firn_bench: throughput of the MPM core on an elastic block (issue: ~200 000 particles, 3D,
// APIC, dx 0.02). Reports particle-steps per second for 1 and N threads, the speed-up, bytes
// per particle and the time share of each stage. Not a test: numbers, not assertions.
//
//   build/firn_bench [--cells CELLS] [--steps N] [--threads N]
//                    [--transfer apic|pic|flip|xpic] [--xpic-order M]
#include "compare_openvdb.h"

#include <firn/resources.h>
#include <firn/scene.h>
#include <firn/solver.h>

#include <tbb/global_control.h>
#include <tbb/info.h>

#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

using namespace firn;

namespace {

struct Options {
    int cells = 30; // block of cells x cells/... see blockScene
    int steps = 60;
    int threads = 0;
    std::string transfer = "apic";
    int xpicOrder = 2; // used by --transfer xpic
    std::string model = "elastic";
    double offset = 0.0; // m, moves the block away from the origin (empty space must cost nothing)
    double domain = 1.0; // > 1: a one-cell marker body stretches the scene's bounds this many
                         // times the block's per axis (2: a domain 8 times the volume)
};

std::string blockScene(const Options& o) {
    // An elastic block of 40 x 25 x 25 cells at dx 0.02 and 8 particles per cell (200 000
    // particles) resting on a frictional floor under gravity.
    const double dx = 0.02;
    const double lx = 40 * dx * o.cells / 30.0, ly = 25 * dx * o.cells / 30.0,
                 lz = 25 * dx * o.cells / 30.0;
    char text[2048];
    std::snprintf(text, sizeof text, R"(
[simulation]
name = "bench"
dimension = 3
end_time = 1.0
[grid]
dx = %g
particles_per_cell = 8
transfer = "%s"
xpic_order = %d
[[material]]
name = "block"
model = "%s"
density = 250.0
youngs_modulus = 1.0e6
poisson_ratio = 0.3
[[terrain]]
shape = "plane"
point = [%g, %g, %g]
normal = [0.0, 1.0, 0.0]
[[body]]
material = "block"
shape = "box"
min = [%g, %g, %g]
max = [%g, %g, %g]
velocity = [0.5, 0.0, 0.0]
)",
                  dx, o.transfer.c_str(), o.xpicOrder, o.model.c_str(), o.offset, o.offset,
                  o.offset, o.offset, o.offset, o.offset, o.offset + lx, o.offset + ly,
                  o.offset + lz);
    std::string scene = text;
    if (o.domain > 1.0) {
        // The marker's far corner sets the bounds: domain x the block on every axis.
        const double fx = o.offset + o.domain * lx, fy = o.offset + o.domain * ly,
                     fz = o.offset + o.domain * lz;
        std::snprintf(text, sizeof text,
                      "[[body]]\nmaterial = \"block\"\nshape = \"box\"\nmin = [%g, %g, %g]\n"
                      "max = [%g, %g, %g]\n",
                      fx - dx, fy - dx, fz - dx, fx, fy, fz);
        scene += text;
    }
    return scene;
}

struct Measurement {
    std::size_t particles = 0;
    double particleStepsPerSecond = 0;
    StepTimings timings;
    double seconds = 0;
};

Measurement measure(const SceneDesc& scene, int threads, int steps) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    auto world = buildWorld(scene);
    step(*world, stableTimeStep(*world)); // warm up: first topology and allocations
    Measurement m;
    const auto t0 = std::chrono::steady_clock::now();
    for (int s = 0; s < steps; ++s) step(*world, stableTimeStep(*world), &m.timings);
    m.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    m.particles = world->particles.size();
    m.particleStepsPerSecond = double(m.particles) * steps / m.seconds;
    return m;
}

void printShares(const Measurement& m) {
    const StepTimings& t = m.timings;
    const double total = t.p2g + t.gridUpdate + t.g2p + t.plasticity + t.sort + t.sleep;
    std::printf("  time share: P2G %.1f %%, grid update %.1f %%, G2P %.1f %%, plasticity %.1f "
                "%%, re-bucketing %.1f %%, sleep pass %.1f %%\n",
                100 * t.p2g / total, 100 * t.gridUpdate / total, 100 * t.g2p / total,
                100 * t.plasticity / total, 100 * t.sort / total, 100 * t.sleep / total);
}

Options parseOptions(int argc, char** argv) {
    Options o;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto value = [&]() -> std::string {
            if (i + 1 >= argc) {
                std::fprintf(stderr, "firn_bench: %s needs a value\n", a.c_str());
                std::exit(1);
            }
            return argv[++i];
        };
        if (a == "--cells")
            o.cells = std::atoi(value().c_str());
        else if (a == "--steps")
            o.steps = std::atoi(value().c_str());
        else if (a == "--threads")
            o.threads = std::atoi(value().c_str());
        else if (a == "--transfer")
            o.transfer = value();
        else if (a == "--xpic-order")
            o.xpicOrder = std::atoi(value().c_str());
        else if (a == "--model")
            o.model = value();
        else if (a == "--offset")
            o.offset = std::atof(value().c_str());
        else if (a == "--domain")
            o.domain = std::atof(value().c_str());
        else {
            std::fprintf(
                stderr,
                "usage: firn_bench [--cells 30] [--steps 60] [--threads N] "
                "[--transfer apic|pic|flip|xpic] [--xpic-order M] [--model elastic|snow|granular] "
                "[--offset M] [--domain SCALE]\n");
            std::exit(a == "--help" ? 0 : 1);
        }
    }
    return o;
}

} // namespace

int main(int argc, char** argv) {
    const Options o = parseOptions(argc, argv);
    const int threads = o.threads > 0 ? o.threads : tbb::info::default_concurrency();
    const SceneDesc scene = parseScene(blockScene(o), "bench/block.toml");
    const double baseline = currentRssBytes(); // libraries (OpenVDB, TBB) before any particle
    std::printf("elastic block, dx 0.02, %s, %s, %d steps\n", o.transfer.c_str(), o.model.c_str(),
                o.steps);

    const Measurement one = measure(scene, 1, o.steps);
    std::printf("%zu particles\n1 thread : %.3g particle-steps/s\n", one.particles,
                one.particleStepsPerSecond);
    printShares(one);
    const Measurement many = measure(scene, threads, o.steps);
    std::printf("%d threads: %.3g particle-steps/s, speed-up %.2f\n", threads,
                many.particleStepsPerSecond,
                many.particleStepsPerSecond / one.particleStepsPerSecond);
    printShares(many);

    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    const double peak = double(usage.ru_maxrss) * 1024.0;
    std::printf("peak RSS %.1f MB: %.0f bytes per particle; without the %.1f MB the process holds "
                "before seeding (shared libraries): %.0f bytes per particle\n",
                peak / 1e6, peak / one.particles, baseline / 1e6,
                (peak - baseline) / one.particles);
    {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        auto world = buildWorld(scene);
        const bench::RasterComparison c = bench::compareWithOpenvdb(world->particles, 5);
        std::printf("P2G against OpenVDB points::rasterizeTrilinear (same particles, %d "
                    "threads): ours %.3g particles/s (quadratic APIC, 27 nodes, 4 channels + "
                    "stress), OpenVDB %.3g particles/s (trilinear, 8 voxels, vec3); ratio %.2f\n",
                    threads, c.particles / c.firnSeconds, c.particles / c.openvdbSeconds,
                    c.openvdbSeconds / c.firnSeconds);
    }
    // One machine-readable line for bench/study.py.
    std::printf("result particles=%zu threads=%d pss1=%.6g pssN=%.6g speedup=%.4g "
                "bytes_per_particle=%.1f bytes_per_particle_net=%.1f\n",
                one.particles, threads, one.particleStepsPerSecond, many.particleStepsPerSecond,
                many.particleStepsPerSecond / one.particleStepsPerSecond, peak / one.particles,
                (peak - baseline) / one.particles);
    return 0;
}
