// Checkpoints: the whole state of a run at the end of an output frame, so that a run killed at
// 90 % (power, a batch queue's wall-time limit, an out-of-memory kill) resumes from there and
// finishes bitwise as it would have without the interruption.
//
// File `checkpoints/checkpoint.NNNN.firn` (NNNN: the frame) in the output folder:
//   "FIRNCKPT" | format version (u32) | payload length (u64) | payload | FNV-1a-64 of payload
// The payload holds the Firn version, a hash of the as-run scene.toml, the scene path, the
// frame, the world (particles with every attribute, plastic and sleep state, time, step) and
// the run loop's own state (trackers, maxima), which it hands over as opaque bytes. Written
// atomically (temporary name, fsync, rename); the last two are kept.
#pragma once

#include <firn/solver.h>

#include <string>
#include <vector>

namespace firn {

/// Bump when the payload's layout changes; older files are then refused with a message.
// 2: peak fields and the COM path; 3: crack ends; 4: the leaves' velocity at the start of quiet;
// 5: the crack's ends timed to the step; 6: the slab's mass and momentum; 7: the settling
// overload's box in scene coordinates (double) and its count per material; 8: slab fractures'
// start; 9: the crack tracker's uncracked extent and each end's reach
constexpr std::uint32_t kCheckpointFormat = 9;

/// "checkpoint.0042.firn".
std::string checkpointFileName(int frame);

/// Writes dir/checkpoint.NNNN.firn (dir is created) and removes all but the newest two.
/// Throws IoError.
void writeCheckpoint(const std::string& dir, int frame, const std::string& sceneToml,
                     const std::string& scenePath, const World& world, const std::string& runState);

struct LoadedCheckpoint {
    std::string file;
    int frame = 0;
    std::string scenePath;             ///< as the interrupted run named its scene
    std::string runState;              ///< the run loop's bytes, as written
    std::vector<std::string> warnings; ///< newer checkpoints skipped as damaged, and why
};

/// Loads the newest valid checkpoint of `dir` into `world` (built from the same scene, with no
/// particles). A truncated or corrupted file (length or checksum) is skipped with a warning and
/// the one before it used. Throws IoError when there is none to use, SceneError when the newest
/// readable one belongs to another scene (`sceneToml` differs) or another Firn version.
LoadedCheckpoint loadNewestCheckpoint(const std::string& dir, const std::string& sceneToml,
                                      World& world);

/// Removes every checkpoint of `dir` (a fresh run into the folder; they belong to the last).
void removeCheckpoints(const std::string& dir);

} // namespace firn
