// What a run will need before it starts: particles and memory estimated from the scene alone,
// against what the machine (or the user) allows. A run that cannot fit is refused at once,
// with the numbers, instead of dying in an allocation an hour later.
#pragma once

#include <firn/errors.h>
#include <firn/scene.h>

#include <string>
#include <vector>

namespace firn {

/// Not enough memory (or another resource) for what the scene asks; exit code 3.
class ResourceError : public FirnError {
public:
    using FirnError::FirnError;
};

/// Peak resident memory of a run: what the process holds before seeding (OpenVDB, TBB, the
/// C++ runtime) plus a cost per particle. Measured (docs/long-runs.md, Resources): 54-65 MB before
/// seeding, 300 bytes per particle over the default 2D scene and the 3D slope (particle arrays
/// 152 B, grid, transfer scratch, a frame's export); rounded up to leave a margin.
constexpr double kBaseBytes = 70e6;
constexpr double kBytesPerParticle = 400.0;

struct MemoryEstimate {
    std::vector<double> particlesPerBody; ///< estimated, see estimateParticlesPerBody
    double particles = 0;
    double bytes = 0;          ///< expected peak RSS
    double availableBytes = 0; ///< what the run may use; infinite when nothing limits it
    std::string limitedBy;     ///< what sets availableBytes ("MemAvailable", "--max-memory", ...)
};

/// Estimates the scene's particles and peak memory and what is available: `maxMemoryBytes`
/// when given (> 0, the user's budget), else the least of the system's available memory, a
/// cgroup limit and the address-space and data ulimits. Fast at any dx (no particle is made).
MemoryEstimate estimateMemory(const SceneDesc& scene, double maxMemoryBytes = 0);

/// Throws ResourceError, with the numbers and what to change, when the estimate exceeds what
/// is available.
void checkMemory(const SceneDesc& scene, const MemoryEstimate& estimate);

/// The process's resident set now, bytes (/proc/self/statm; 0 where it cannot be read).
double currentRssBytes();

/// "1.5 GB" style.
std::string formatBytes(double bytes);

/// "4G", "512M", "2.5GB", "1000000" (bytes) -> bytes; throws std::invalid_argument.
double parseByteSize(const std::string& text);

} // namespace firn
