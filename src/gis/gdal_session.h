// GDAL's process-wide set-up, done once before the first use, and an owning dataset handle.
#pragma once

#include <gdal.h>

#include <memory>

namespace firn::gis {

struct DatasetCloser {
    void operator()(void* dataset) const { GDALClose(GDALDatasetH(dataset)); }
};
/// A GDAL dataset (raster or vector), closed when it goes.
using Dataset = std::unique_ptr<void, DatasetCloser>;

/// Registers GDAL's drivers and keeps its messages off stderr: Firn reports GDAL's last error
/// in its own messages (CPLGetLastErrorMsg). Thread-safe; the first call does the work.
void ensureGdal();

} // namespace firn::gis
