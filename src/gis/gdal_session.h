// GDAL's process-wide set-up, done once before the first use.
#pragma once

namespace firn::gis {

/// Registers GDAL's drivers and keeps its messages off stderr: Firn reports GDAL's last error
/// in its own messages (CPLGetLastErrorMsg). Thread-safe; the first call does the work.
void ensureGdal();

} // namespace firn::gis
