// Reading particle caches back (outputs.md: frames/particles.NNNN.vdb, PointDataGrid "points").
// Kept apart from the binning so that only this translation unit pays for OpenVDB's point
// headers.
#pragma once

#include <firn/io.h>

#include <string>
#include <vector>

namespace firn::report {

/// One particle cache file: its metadata and its particles (every outputs.md attribute).
struct CachedFrame {
    FrameInfo info;
    ParticleFrame particles;
};

/// Reads `path`. Throws IoError naming the file when it cannot be read, has no grid "points"
/// or lacks an attribute.
CachedFrame readParticleFrame(const std::string& path);

/// Frame numbers of the particles.NNNN.vdb files in `framesDir`, ascending; empty when the
/// folder does not exist (a run with output.particles = false).
std::vector<int> listParticleFrames(const std::string& framesDir);

} // namespace firn::report
