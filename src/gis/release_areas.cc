// Release areas from vector files through OGR's C API.
#include "gdal_session.h"

#include <firn/errors.h>
#include <firn/gis.h>

#include <gdal.h>
#include <ogr_api.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <sstream>

namespace firn {

namespace {

[[noreturn]] void fail(const BodyDesc& body, const std::string& what) {
    throw SceneError(body.loc, "body: file", body.footprintFile + ": " + what);
}

using gis::Dataset;

/// The rings of one polygon geometry, moved into the local frame.
void addPolygon(OGRGeometryH polygon, const Vec3d& origin, ReleaseArea& area) {
    for (int k = 0; k < OGR_G_GetGeometryCount(polygon); ++k) {
        OGRGeometryH ring = OGR_G_GetGeometryRef(polygon, k);
        std::vector<std::array<double, 2>> points;
        for (int i = 0; i < OGR_G_GetPointCount(ring); ++i)
            points.push_back({OGR_G_GetX(ring, i) - origin[0], OGR_G_GetY(ring, i) - origin[2]});
        if (points.size() >= 3) area.rings.push_back(std::move(points));
    }
}

void computeBounds(ReleaseArea& area) {
    area.xMin = area.zMin = INFINITY;
    area.xMax = area.zMax = -INFINITY;
    for (const auto& ring : area.rings)
        for (const auto& p : ring) {
            area.xMin = std::min(area.xMin, p[0]), area.xMax = std::max(area.xMax, p[0]);
            area.zMin = std::min(area.zMin, p[1]), area.zMax = std::max(area.zMax, p[1]);
        }
}

std::string number(double v) {
    std::ostringstream out;
    out << v;
    return out.str();
}

} // namespace

bool ReleaseArea::contains(double x, double z) const {
    if (x < xMin || x > xMax || z < zMin || z > zMax) return false;
    bool inside = false;
    for (const auto& ring : rings) {
        const std::size_t n = ring.size();
        for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
            const auto &a = ring[i], &b = ring[j];
            if ((a[1] > z) != (b[1] > z) && x < a[0] + (z - a[1]) * (b[0] - a[0]) / (b[1] - a[1]))
                inside = !inside;
        }
    }
    return inside;
}

std::vector<ReleaseArea> readReleaseAreas(const BodyDesc& body) {
    gis::ensureGdal();
    CPLErrorReset();
    Dataset dataset(GDALOpenEx(body.footprintFile.c_str(), GDAL_OF_VECTOR | GDAL_OF_READONLY,
                               nullptr, nullptr, nullptr));
    if (!dataset) {
        const std::string why = CPLGetLastErrorMsg();
        fail(body, "OGR cannot read it as a vector file" + (why.empty() ? "" : ": " + why));
    }
    std::vector<ReleaseArea> areas;
    gis::forEachFeature(dataset.get(), [&](OGRFeatureH f, OGRGeometryH geometry) {
        const OGRwkbGeometryType type = wkbFlatten(OGR_G_GetGeometryType(geometry));
        if (type != wkbPolygon && type != wkbMultiPolygon) return true;
        ReleaseArea area;
        area.label = "feature " + std::to_string(OGR_F_GetFID(f));
        if (type == wkbPolygon) {
            addPolygon(geometry, body.footprintOrigin, area);
        } else {
            for (int k = 0; k < OGR_G_GetGeometryCount(geometry); ++k)
                addPolygon(OGR_G_GetGeometryRef(geometry, k), body.footprintOrigin, area);
        }
        if (area.rings.empty()) return true;
        if (body.thickness > 0.0) {
            area.thickness = body.thickness;
        } else {
            const int field = OGR_F_GetFieldIndex(f, body.thicknessAttribute.c_str());
            if (field < 0 || !OGR_F_IsFieldSetAndNotNull(f, field))
                fail(body, area.label + " has no '" + body.thicknessAttribute +
                               "' attribute: give the body a thickness, or the feature one");
            area.thickness = OGR_F_GetFieldAsDouble(f, field);
            if (!(area.thickness > 0.0 && std::isfinite(area.thickness)))
                fail(body, area.label + ": thickness " + number(area.thickness) + " m must be > 0");
        }
        computeBounds(area);
        areas.push_back(std::move(area));
        return true;
    });
    if (areas.empty()) fail(body, "holds no polygon");
    return areas;
}

} // namespace firn
