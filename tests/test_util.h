// Helpers shared by the tests: scenes from text, worlds run to a time, temporary folders.
#pragma once

#include <firn/diagnostics.h>
#include <firn/scene.h>
#include <firn/solver.h>

#include <Eigen/Dense>

#include <cmath>
#include <filesystem>
#include <memory>
#include <string>
#include <unistd.h>
#include <vector>

namespace firn::test {

/// A 2D granular box resting on a plane: 200 particles, 4 frames, well under a second. Tests
/// that make bad scenes replace one line of it, so its line numbers matter.
inline const std::string kTinyScene = R"([simulation]
name = "tiny"
dimension = 2
end_time = 0.1
frame_rate = 30

[grid]
dx = 0.1
particles_per_cell = 4

[[material]]
name = "snow"
model = "granular"

[[terrain]]
shape = "plane"
point = [0.0, 0.0]
normal = [0.0, 1.0]

[[body]]
material = "snow"
shape = "box"
min = [0.0, 0.0]
max = [1.0, 0.5]
)";

/// Parses scene text as if it came from "tests/<name>.toml".
inline SceneDesc sceneFromText(const std::string& text, const std::string& name = "inline") {
    return parseScene(text, "tests/" + name + ".toml");
}

/// Steps a world at its stable time step until `endTime`, landing on it exactly.
inline void advanceTo(World& world, double endTime) {
    while (world.time < endTime - 1e-12)
        step(world, std::min(stableTimeStep(world), endTime - world.time));
}

/// The bed-law tests' inclined plane (2D, at dx): a 4 m x 1 m elastic slab (300 kg/m^3,
/// E 3e5 Pa) resting on the plane y = 0 under gravity tilted by `slopeDeg`, the plane's
/// [[terrain]] table ending with `bedKeys` (its boundary and the law's coefficients).
inline std::unique_ptr<World> slabOnTiltedBed(const std::string& name, const std::string& bedKeys,
                                              double slopeDeg, double dx) {
    const double g = 9.81, th = slopeDeg * 3.14159265358979323846 / 180.0;
    std::string text =
        "[simulation]\nname = \"" + name + "\"\ndimension = 2\nend_time = 5.0\ngravity = [" +
        std::to_string(g * std::sin(th)) + ", " + std::to_string(-g * std::cos(th)) + "]\n";
    text += "[[terrain]]\nshape = \"plane\"\npoint = [0.0, 0.0]\nnormal = [0.0, 1.0]\n" + bedKeys;
    text += "[[material]]\nname = \"slab\"\nmodel = \"elastic\"\ndensity = 300.0\n"
            "youngs_modulus = 3.0e5\npoisson_ratio = 0.3\n";
    text += "[[body]]\nmaterial = \"slab\"\nshape = \"box\"\nmin = [0.0, 0.0]\nmax = [4.0, 1.0]\n";
    text += "[grid]\ndx = " + std::to_string(dx) + "\nparticles_per_cell = 4\nsleep = false\n";
    return buildWorld(sceneFromText(text, name));
}

/// The world's mean velocity along x, m/s.
inline double meanSpeedX(const World& w) {
    const FrameDiagnostics d = computeDiagnostics(w);
    return d.momentum[0] / d.mass;
}

/// Least-squares fit s(t) = s0 + v0 t + a/2 t^2 of a path sampled at times t; returns a.
inline double fitAcceleration(const std::vector<double>& t, const std::vector<double>& s) {
    Eigen::MatrixXd A(t.size(), 3);
    Eigen::VectorXd b(t.size());
    for (std::size_t i = 0; i < t.size(); ++i) {
        A.row(i) << 1.0, t[i], 0.5 * t[i] * t[i];
        b[i] = s[i];
    }
    return A.colPivHouseholderQr().solve(b)[2];
}

/// A fresh empty folder under the system temp dir, removed when the object dies.
class TempDir {
public:
    explicit TempDir(const std::string& stem) {
        static int counter = 0;
        mPath = std::filesystem::temp_directory_path() /
                (stem + "-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
        std::filesystem::remove_all(mPath);
        std::filesystem::create_directories(mPath);
    }
    ~TempDir() { std::filesystem::remove_all(mPath); }
    std::string path() const { return mPath.string(); }

private:
    std::filesystem::path mPath;
};

} // namespace firn::test
