// Helpers shared by the tests: scenes from text, worlds run to a time, temporary folders.
#pragma once

#include <firn/scene.h>
#include <firn/solver.h>

#include <Eigen/Dense>

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
