// firn_pst_onset: which criterion starts the crack in the PST (README, Snow). Runs
// scenes/pst.toml on a 3 m column at a slope with a cut at the down-slope end and stops at the
// first frame where weak-layer particles ahead of the cut tip have yielded; prints where they sit
// on the Cam-Clay surface: pressure p against the ellipse centre p_c = (1 - beta) p0 / 2 (above
// it: the compression side, where shear compacts; below it: the tension side, where shear
// dilates) and q / p (shear against confinement). Not a test: numbers, not assertions.
//
//   build/firn_pst_onset [--slope DEG] [--cut M] [--dx M] [--scene scenes/pst.toml]
#include <firn/scene.h>
#include <firn/solver.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

using namespace firn;

int main(int argc, char** argv) {
    double slope = 0.0, cut = 0.4, dx = 0.03;
    std::string scenePath = "scenes/pst.toml";
    for (int i = 1; i + 1 < argc; i += 2) {
        if (!std::strcmp(argv[i], "--slope"))
            slope = std::atof(argv[i + 1]);
        else if (!std::strcmp(argv[i], "--cut"))
            cut = std::atof(argv[i + 1]);
        else if (!std::strcmp(argv[i], "--dx"))
            dx = std::atof(argv[i + 1]);
        else if (!std::strcmp(argv[i], "--scene"))
            scenePath = argv[i + 1];
        else {
            std::fprintf(stderr, "usage: firn_pst_onset [--slope DEG] [--cut M] [--dx M] "
                                 "[--scene FILE]\n");
            return 1;
        }
    }
    const double psi = slope * M_PI / 180.0, length = 3.0, tip = length - cut;
    char gravity[96];
    std::snprintf(gravity, sizeof gravity, "simulation.gravity=[%.6f, %.6f]", 9.81 * std::sin(psi),
                  -9.81 * std::cos(psi));
    const SceneDesc scene = loadScene(
        scenePath, {gravity, "grid.dx=" + std::to_string(dx), "body.weak.x_range=[0.0, 3.0]",
                    "body.slab.x_range=[0.0, 3.0]", "cut.weak.from_x=" + std::to_string(tip),
                    "cut.weak.length=" + std::to_string(cut)});
    auto world = buildWorld(scene);
    std::printf("slope %.0f deg, cut %.3f m, dx %.3f m: settled in %.3f s\n", slope, cut, dx,
                world->settle.time);
    const double frame = 0.002;
    for (int k = 1; k <= 100; ++k) {
        while (world->time < k * frame - 1e-12)
            step(*world, std::min(stableTimeStep(*world), k * frame - world->time));
        const ParticleSet& ps = world->particles;
        int n = 0;
        double sumP = 0, sumPc = 0, sumQ = 0, above = 0;
        for (std::size_t i = 0; i < ps.size(); ++i) {
            const Material& m = world->materials[ps.material[i]];
            // Ahead of the tip by more than a cell: not the cut face itself.
            if (m.model != MaterialModel::WeakLayer || !(ps.plastic[i].flags & kFlagFailed) ||
                ps.x[i][0] > tip - dx)
                continue;
            const Sym3f& t = ps.tau[i];
            const double mean = 0.5 * (t.xx + t.yy);
            const double radius = std::hypot(0.5 * (t.xx - t.yy), t.xy);
            const Vec3f principal(float(mean + radius), float(mean - radius), 0.f);
            const StressInvariants inv = stressInvariants(principal, 2);
            const float K = m.lame.bulkModulus(2);
            const double p0 = (ps.plastic[i].flags & kFlagCollapsed)
                                  ? 0.0
                                  : camClayP0(K, m.camClay.xi, ps.plastic[i].hardening);
            const double pc = 0.5 * (1.0 - m.camClay.beta) * p0;
            ++n, sumP += inv.p, sumPc += pc, sumQ += inv.q, above += inv.p > pc;
        }
        if (n == 0) continue;
        std::printf("first yield ahead of the tip at t = %.3f s: %d particles, mean p = %.0f Pa, "
                    "p_c = %.0f Pa, q = %.0f Pa, q/p = %.2f; %.0f %% on the compression side "
                    "(p > p_c)\n",
                    world->time, n, sumP / n, sumPc / n, sumQ / n, sumQ / sumP, 100.0 * above / n);
        return 0;
    }
    std::printf("no yield ahead of the tip within 0.2 s\n");
    return 0;
}
