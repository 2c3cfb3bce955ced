// Writes the synthetic avalanche path of scenes/path3d/: a GeoTIFF DEM and a release shapefile
// in Swiss coordinates (EPSG:2056), as a practitioner's files would come.
//
// The path runs east: a parabolic thalweg y(s) = tan(35 deg) (L - s)^2 / (2 L) falling 350 m
// over L = 1000 m (35 degrees at the top, flat from s = L), then a flat runout to 1600 m; across
// it a shallow channel, + 0.0005 (z - 200)^2 m. The release is a 200 m x 300 m rectangle at
// s = 50-250 m, 1 m thick (60 000 m^3), as attribute "thickness".
//
//   firn_synthetic_path OUT_DIR [--cell 5] [--rotate DEG]
// --rotate turns the whole path (DEM and release) about the release's centre by DEG degrees
// about the vertical: the same avalanche in another grid direction (V11's rotated-DEM check).
#include <cpl_conv.h>
#include <gdal.h>
#include <ogr_api.h>
#include <ogr_srs_api.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace {

constexpr double kEast = 2600000.0, kNorth = 1200000.0; // south-west corner, LV95
constexpr double kLength = 1600.0, kWidth = 400.0;      // m
constexpr double kParabola = 1000.0;                    // m
constexpr double kPi = 3.14159265358979323846;

struct Frame {
    double angle = 0.0;            // radians, counter-clockwise from east
    double cx = 150.0, cz = 200.0; // the rotation centre (the release's), path coordinates
    // Path coordinates (s along, z across) of a map point (x east, z north), relative to the
    // corner.
    void toPath(double x, double z, double& s, double& t) const {
        const double dx = x - cx, dz = z - cz, c = std::cos(angle), n = std::sin(angle);
        s = cx + c * dx + n * dz;
        t = cz - n * dx + c * dz;
    }
    void toMap(double s, double t, double& x, double& z) const {
        const double ds = s - cx, dt = t - cz, c = std::cos(angle), n = std::sin(angle);
        x = cx + c * ds - n * dt;
        z = cz + n * ds + c * dt;
    }
};

double height(double s, double t) {
    const double slope = std::tan(35.0 * kPi / 180.0);
    const double along =
        s < kParabola ? slope * (kParabola - s) * (kParabola - s) / (2 * kParabola) : 0.0;
    return 1200.0 + along + 0.0005 * (t - 200.0) * (t - 200.0);
}

char* swissWkt() {
    OGRSpatialReferenceH srs = OSRNewSpatialReference(nullptr);
    OSRImportFromEPSG(srs, 2056);
    char* wkt = nullptr;
    OSRExportToWkt(srs, &wkt);
    OSRDestroySpatialReference(srs);
    return wkt;
}

bool writeDem(const std::string& path, double cell, const Frame& f) {
    // A rotated path needs a larger map: the bounding box of the rotated path's rectangle.
    double x0 = 1e300, x1 = -1e300, z0 = 1e300, z1 = -1e300;
    for (const double s : {0.0, kLength})
        for (const double across : {0.0, kWidth}) {
            double x = 0, z = 0;
            f.toMap(s, across, x, z);
            x0 = std::min(x0, x), x1 = std::max(x1, x), z0 = std::min(z0, z), z1 = std::max(z1, z);
        }
    x0 = cell * std::floor(x0 / cell), z0 = cell * std::floor(z0 / cell);
    const int columns = int(std::ceil((x1 - x0) / cell)), rows = int(std::ceil((z1 - z0) / cell));
    GDALDatasetH d = GDALCreate(GDALGetDriverByName("GTiff"), path.c_str(), columns, rows, 1,
                                GDT_Float32, nullptr);
    if (!d) return false;
    double t[6] = {kEast + x0, cell, 0.0, kNorth + z0 + rows * cell, 0.0, -cell};
    GDALSetGeoTransform(d, t);
    char* wkt = swissWkt();
    GDALSetProjection(d, wkt);
    CPLFree(wkt);
    std::vector<float> row(static_cast<std::size_t>(columns));
    for (int r = 0; r < rows; ++r) {
        for (int c = 0; c < columns; ++c) {
            double s = 0, across = 0;
            f.toPath(x0 + (c + 0.5) * cell, z0 + (rows - r - 0.5) * cell, s, across);
            row[std::size_t(c)] = float(height(s, across));
        }
        if (GDALRasterIO(GDALGetRasterBand(d, 1), GF_Write, 0, r, columns, 1, row.data(), columns,
                         1, GDT_Float32, 0, 0) != CE_None)
            return false;
    }
    GDALClose(d);
    return true;
}

bool writeRelease(const std::string& path, const Frame& f) {
    GDALDatasetH d = GDALCreate(GDALGetDriverByName("ESRI Shapefile"), path.c_str(), 0, 0, 0,
                                GDT_Unknown, nullptr);
    if (!d) return false;
    OGRSpatialReferenceH srs = OSRNewSpatialReference(nullptr);
    OSRImportFromEPSG(srs, 2056);
    OGRLayerH layer = GDALDatasetCreateLayer(d, "release", srs, wkbPolygon, nullptr);
    OSRDestroySpatialReference(srs);
    OGRFieldDefnH field = OGR_Fld_Create("thickness", OFTReal);
    OGR_L_CreateField(layer, field, TRUE);
    OGR_Fld_Destroy(field);
    OGRFeatureH feature = OGR_F_Create(OGR_L_GetLayerDefn(layer));
    OGR_F_SetFieldDouble(feature, OGR_F_GetFieldIndex(feature, "thickness"), 1.0);
    OGRGeometryH ring = OGR_G_CreateGeometry(wkbLinearRing);
    const double corners[5][2] = {{50, 50}, {250, 50}, {250, 350}, {50, 350}, {50, 50}};
    for (const auto& c : corners) {
        double x = 0, z = 0;
        f.toMap(c[0], c[1], x, z);
        OGR_G_AddPoint_2D(ring, kEast + x, kNorth + z);
    }
    OGRGeometryH polygon = OGR_G_CreateGeometry(wkbPolygon);
    OGR_G_AddGeometryDirectly(polygon, ring);
    OGR_F_SetGeometryDirectly(feature, polygon);
    const bool ok = OGR_L_CreateFeature(layer, feature) == OGRERR_NONE;
    OGR_F_Destroy(feature);
    GDALClose(d);
    return ok;
}

} // namespace

int main(int argc, char** argv) {
    std::string out;
    double cell = 5.0, rotateDeg = 0.0;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--cell" && i + 1 < argc) {
            cell = std::atof(argv[++i]);
        } else if (a == "--rotate" && i + 1 < argc) {
            rotateDeg = std::atof(argv[++i]);
        } else if (out.empty() && a[0] != '-') {
            out = a;
        } else {
            std::fprintf(stderr, "usage: firn_synthetic_path OUT_DIR [--cell 5] [--rotate DEG]\n");
            return 1;
        }
    }
    if (out.empty() || !(cell > 0.0)) {
        std::fprintf(stderr, "usage: firn_synthetic_path OUT_DIR [--cell 5] [--rotate DEG]\n");
        return 1;
    }
    GDALAllRegister();
    Frame f;
    f.angle = rotateDeg * kPi / 180.0;
    if (!writeDem(out + "/dem.tif", cell, f) || !writeRelease(out + "/release.shp", f)) {
        std::fprintf(stderr, "firn_synthetic_path: cannot write into %s: %s\n", out.c_str(),
                     CPLGetLastErrorMsg());
        return 1;
    }
    std::printf("wrote %s/dem.tif and %s/release.shp (cell %g m, rotated %g deg)\n", out.c_str(),
                out.c_str(), cell, rotateDeg);
    return 0;
}
