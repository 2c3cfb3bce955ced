// Running a scene end to end: setup, the step loop with frame output, progress, the stability
// watch and the summary (outputs.md).
#pragma once

#include <firn/scene.h>

#include <string>

namespace firn {

struct RunOptions {
    int threads = 0;    ///< 0: all cores
    std::string outDir; ///< overrides output.directory when not empty
    bool quiet = false; ///< no progress output
};

struct RunResult {
    std::string status = "ok"; ///< "ok" | "unstable" | "interrupted"
    std::string message;       ///< why a run stopped early
    std::string outDir;
    long long steps = 0;
    int frames = 0; ///< frames written, including frame 0
    std::size_t particles = 0;
    double wallSeconds = 0;
};

/// Runs the scene and writes caches, metrics.csv, summary.json and scene.toml into the output
/// folder. Throws SceneError (bad scene) or IoError (cannot write); an unstable run returns
/// with status "unstable" after writing its summary.
RunResult runScene(const SceneDesc& scene, const RunOptions& options);

/// What `firn check` prints: particles per body, grid spacing, time step and step estimate.
std::string describeScene(const SceneDesc& scene);

} // namespace firn
