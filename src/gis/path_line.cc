// An avalanche's path line from a vector file through OGR's C API.
#include "gdal_session.h"

#include <firn/errors.h>
#include <firn/gis.h>

#include <gdal.h>
#include <ogr_api.h>


namespace firn {

namespace {

[[noreturn]] void fail(const OutputDesc& output, const std::string& what) {
    throw SceneError(output.loc, "output.path", output.path + ": " + what);
}

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
    std::vector<std::array<double, 2>> line;
    gis::forEachFeature(dataset.get(), [&](OGRFeatureH, OGRGeometryH geometry) {
        OGRwkbGeometryType type = wkbFlatten(OGR_G_GetGeometryType(geometry));
        if (type == wkbMultiLineString && OGR_G_GetGeometryCount(geometry) > 0) {
            geometry = OGR_G_GetGeometryRef(geometry, 0);
            type = wkbFlatten(OGR_G_GetGeometryType(geometry));
        }
        if (type != wkbLineString) return true;
        for (int i = 0; i < OGR_G_GetPointCount(geometry); ++i)
            line.push_back(
                {OGR_G_GetX(geometry, i) - origin[0], OGR_G_GetY(geometry, i) - origin[2]});
        return false; // the first line: AvaFrame's path_aimec holds one
    });
    if (line.empty()) fail(output, "it holds no line (LineString) feature");
    if (line.size() < 2) fail(output, "its first line has fewer than two points");
    return line;
}

} // namespace firn
