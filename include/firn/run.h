// Running a scene end to end: setup, the step loop with frame output, progress, the stability
// watch and the summary (outputs.md).
#pragma once

#include <firn/scene.h>

#include <string>

namespace firn {

struct RunOptions {
    int threads = 0;           ///< 0: all cores
    std::string outDir;        ///< overrides output.directory when not empty
    bool quiet = false;        ///< no progress output
    double maxMemoryBytes = 0; ///< the memory budget (--max-memory); 0: what the machine has
    /// Checkpoint interval (--checkpoint-every); negative: the scene's output keys.
    int checkpointEveryFrames = -1;
    double checkpointEveryMinutes = -1;
    /// Continue the run in outDir from its newest checkpoint (firn run --resume). The scene is
    /// the folder's scene.toml, whose text is `resumeSceneToml`.
    bool resume = false;
    std::string resumeSceneToml;
};

struct RunResult {
    std::string status = "ok"; ///< "ok" | "unstable" | "interrupted" | "io_error"
    std::string message;       ///< why a run stopped early
    std::string outDir;
    long long steps = 0;
    int frames = 0; ///< frames written, including frame 0
    std::size_t particles = 0;
    double wallSeconds = 0;
    int resumedFromFrame = -1; ///< the checkpoint's frame when resumed, else -1
};

/// Runs the scene and writes caches, metrics.csv, summary.json and scene.toml into the output
/// folder. Throws SceneError (bad scene), ResourceError (the run would not fit in memory:
/// checked before anything is written) or IoError (cannot write); an unstable run returns
/// with status "unstable" after writing its summary.
RunResult runScene(const SceneDesc& scene, const RunOptions& options);

/// What `firn check` prints: particles per body, grid spacing, time step and step estimate,
/// and the memory estimate against `maxMemoryBytes` (0: what the machine has). Seeds the scene
/// for exact counts only when the estimate is small enough to do that in about a second.
std::string describeScene(const SceneDesc& scene, double maxMemoryBytes = 0);

} // namespace firn
