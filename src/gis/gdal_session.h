// GDAL's process-wide set-up, done once before the first use, and an owning dataset handle.
#pragma once

#include <gdal.h>
#include <ogr_api.h>

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

struct FeatureDestroyer {
    void operator()(void* feature) const { OGR_F_Destroy(OGRFeatureH(feature)); }
};

/// Calls visit(feature, geometry) for every feature that has a geometry, layer by layer in the
/// file's order, until visit returns false.
template <typename Visit> void forEachFeature(GDALDatasetH dataset, Visit&& visit) {
    for (int l = 0; l < GDALDatasetGetLayerCount(dataset); ++l) {
        OGRLayerH layer = GDALDatasetGetLayer(dataset, l);
        OGR_L_ResetReading(layer);
        while (true) {
            std::unique_ptr<void, FeatureDestroyer> feature(OGR_L_GetNextFeature(layer));
            if (!feature) break;
            OGRGeometryH geometry = OGR_F_GetGeometryRef(OGRFeatureH(feature.get()));
            if (geometry && !visit(OGRFeatureH(feature.get()), geometry)) return;
        }
    }
}

} // namespace firn::gis
