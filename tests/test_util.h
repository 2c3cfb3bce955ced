// Helpers shared by the tests: scenes from text, worlds run to a time, temporary folders.
#pragma once

#include <firn/scene.h>
#include <firn/solver.h>

#include <filesystem>
#include <memory>
#include <string>
#include <unistd.h>

namespace firn::test {

/// Parses scene text as if it came from "tests/<name>.toml".
inline SceneDesc sceneFromText(const std::string& text, const std::string& name = "inline") {
    return parseScene(text, "tests/" + name + ".toml");
}

/// Steps a world at its stable time step until `endTime`, landing on it exactly.
inline void advanceTo(World& world, double endTime) {
    while (world.time < endTime - 1e-12)
        step(world, std::min(stableTimeStep(world), endTime - world.time));
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
