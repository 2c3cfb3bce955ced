// firn_slab_drag: what holds a released slab back (README, Slope-scale runs). Runs
// bench/slab_drag.toml (a slab on a weak layer on a straight 45 degree slope, the crack started by
// a dropped block) and prints, every 0.1 s, the slab's mean speed along the slope over
// x = 3-6 m and the weak layer's mean stresses there in the slope's frame: normal sigma_n, shear
// tau and their ratio. A slab held only by its weak layer accelerates at
// g (sin 45 - |tau / sigma_n| cos 45); a slower one is held by something else (the transfers).
// Not a test: numbers, not assertions.
//
//   build/firn_slab_drag [--scene bench/slab_drag.toml] [--set key=value ...]
#include <firn/scene.h>
#include <firn/solver.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

using namespace firn;

int main(int argc, char** argv) {
    std::string scenePath = "bench/slab_drag.toml";
    std::vector<std::string> sets;
    for (int i = 1; i + 1 < argc; i += 2) {
        if (!std::strcmp(argv[i], "--scene"))
            scenePath = argv[i + 1];
        else if (!std::strcmp(argv[i], "--set"))
            sets.push_back(argv[i + 1]);
        else {
            std::fprintf(stderr, "usage: firn_slab_drag [--scene FILE] [--set key=value ...]\n");
            return 1;
        }
    }
    const SceneDesc scene = loadScene(scenePath, sets);
    auto world = buildWorld(scene);
    // Along the slope t = (c, -s), its outward normal n = (s, c).
    const double c = std::cos(M_PI / 4), s = std::sin(M_PI / 4);
    const double tx = c, ty = -s, nx = s, ny = c;
    std::printf("time_s,slab_speed_m_s,weak_sigma_n_pa,weak_tau_pa,tau_over_sigma_n\n");
    const int frames = int(std::lround(scene.simulation.endTime / 0.1));
    for (int k = 1; k <= frames; ++k) {
        const double end = 0.1 * k;
        while (world->time < end - 1e-12)
            step(*world, std::min(stableTimeStep(*world), end - world->time));
        const ParticleSet& ps = world->particles;
        double momentum = 0, mass = 0, sigmaN = 0, tau = 0;
        int weak = 0;
        for (std::size_t i = 0; i < ps.size(); ++i) {
            if (ps.x[i][0] < 3.0 || ps.x[i][0] > 6.0) continue;
            const Material& m = world->materials[ps.material[i]];
            if (m.slab) {
                momentum += ps.mass[i] * (ps.v[i][0] * tx + ps.v[i][1] * ty);
                mass += ps.mass[i];
            }
            if (m.model != MaterialModel::WeakLayer) continue;
            const Sym3f& t = ps.tau[i]; // Kirchhoff stress: J sigma, J near 1 here
            sigmaN += nx * nx * t.xx + 2 * nx * ny * t.xy + ny * ny * t.yy;
            tau += tx * nx * t.xx + (tx * ny + ty * nx) * t.xy + ty * ny * t.yy;
            ++weak;
        }
        if (weak == 0 || mass == 0) continue;
        std::printf("%.2f,%.4f,%.1f,%.1f,%.4f\n", end, momentum / mass, sigmaN / weak, tau / weak,
                    std::abs(tau / sigmaN));
        std::fflush(stdout);
    }
    return 0;
}
