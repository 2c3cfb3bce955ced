// An avalanche's path line from a vector file through OGR's C API.
#include "gdal_session.h"

#include <firn/errors.h>
#include <firn/gis.h>

#include <gdal.h>
#include <ogr_api.h>

#include <memory>

namespace firn {

namespace {

[[noreturn]] void fail(const OutputDesc& output, const std::string& what) {
    throw SceneError(output.loc, "output.path", output.path + ": " + what);
}

struct FeatureDeleter {
    void operator()(void* f) const { OGR_F_Destroy(OGRFeatureH(f)); }
};

} // namespace

std::vector<std::array<double, 2>> readPathLine(const OutputDesc& output, const Vec3d& origin) {
    gis::ensureGdal();
    CPLErrorReset();
    gis::Dataset dataset(GDALOpenEx(output.path.c_str(), GDAL_OF_VECTOR | GDAL_OF_READONLY, nullptr,
                                    nullptr, nullptr));
    if (!dataset) {
        const std::string why = CPLGetLastErrorMsg();
        fail(output, "OGR cannot read it as a vector file" + (why.empty() ? "" : ": " + why));
    }
    for (int l = 0; l < GDALDatasetGetLayerCount(dataset.get()); ++l) {
        OGRLayerH layer = GDALDatasetGetLayer(dataset.get(), l);
        OGR_L_ResetReading(layer);
        while (true) {
            std::unique_ptr<void, FeatureDeleter> feature(OGR_L_GetNextFeature(layer));
            if (!feature) break;
            OGRGeometryH geometry = OGR_F_GetGeometryRef(OGRFeatureH(feature.get()));
            if (!geometry) continue;
            OGRwkbGeometryType type = wkbFlatten(OGR_G_GetGeometryType(geometry));
            if (type == wkbMultiLineString && OGR_G_GetGeometryCount(geometry) > 0) {
                geometry = OGR_G_GetGeometryRef(geometry, 0);
                type = wkbFlatten(OGR_G_GetGeometryType(geometry));
            }
            if (type != wkbLineString) continue;
            std::vector<std::array<double, 2>> line;
            for (int i = 0; i < OGR_G_GetPointCount(geometry); ++i)
                line.push_back(
                    {OGR_G_GetX(geometry, i) - origin[0], OGR_G_GetY(geometry, i) - origin[2]});
            if (line.size() < 2) fail(output, "its first line has fewer than two points");
            return line; // the first line: AvaFrame's path_aimec holds one
        }
    }
    fail(output, "it holds no line (LineString) feature");
}

} // namespace firn
