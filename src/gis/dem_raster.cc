// DEM rasters through GDAL's C API (stable across GDAL versions, and light to compile).
#include "gdal_session.h"

#include <firn/errors.h>
#include <firn/gis.h>

#include <gdal.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <sstream>
#include <vector>

namespace firn {

namespace {

/// Larger grids would need gigabytes of heights; no avalanche path needs them at a useful cell.
constexpr double kMaxCells = 4e8;

[[noreturn]] void fail(const std::string& path, const std::string& what) {
    throw SceneError(SourceLoc{path, 0, 0}, "heightfield", what);
}

bool isEsriAscii(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    return ext == ".asc";
}

std::string number(double v) {
    std::ostringstream out;
    out << v;
    return out.str();
}

/// The georeference of an open dataset; a rotated or non-square grid is an error.
Georeference georeferenceOf(GDALDatasetH dataset, const std::string& path) {
    Georeference geo;
    geo.columns = GDALGetRasterXSize(dataset);
    geo.rows = GDALGetRasterYSize(dataset);
    double t[6] = {0, 1, 0, 0, 0, 1};
    if (GDALGetGeoTransform(dataset, t) != CE_None)
        fail(path, "has no georeference (no geotransform): Firn needs the cell size and corner");
    if (t[2] != 0.0 || t[4] != 0.0)
        fail(path, "is rotated (geotransform terms " + number(t[2]) + ", " + number(t[4]) +
                       "): warp it north-up first (gdalwarp)");
    const double cell = t[1];
    if (!(cell > 0.0) || std::abs(std::abs(t[5]) - cell) > 1e-9 * cell)
        fail(path, "has cells of " + number(t[1]) + " x " + number(std::abs(t[5])) +
                       " m: Firn needs square cells (gdalwarp -tr " + number(t[1]) + " " +
                       number(t[1]) + ")");
    geo.cell = cell;
    geo.west = t[0];
    // North-up (t[5] < 0): the origin is the north-west corner; south-up: the south-west one.
    geo.south = t[5] < 0.0 ? t[3] + t[5] * geo.rows : t[3];
    if (const char* wkt = GDALGetProjectionRef(dataset)) geo.crsWkt = wkt;
    return geo;
}

using gis::Dataset;

Dataset openRaster(const std::string& path) {
    gis::ensureGdal();
    CPLErrorReset();
    Dataset d(
        GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr));
    if (!d) {
        const std::string why = CPLGetLastErrorMsg();
        fail(path, "GDAL cannot read it as a raster" + (why.empty() ? "" : ": " + why));
    }
    if (GDALGetRasterCount(d.get()) < 1) fail(path, "has no raster band");
    return d;
}

/// Heights of band 1 as rows from the south, NODATA (and NaN) cells as NaN.
std::vector<float> readHeights(GDALDatasetH dataset, const Georeference& geo,
                               const std::string& path, bool southUp) {
    GDALRasterBandH band = GDALGetRasterBand(dataset, 1);
    int hasNoData = 0;
    const double noData = GDALGetRasterNoDataValue(band, &hasNoData);
    std::vector<float> heights(std::size_t(geo.columns) * std::size_t(geo.rows));
    std::vector<double> row(std::size_t(geo.columns));
    for (int fileRow = 0; fileRow < geo.rows; ++fileRow) {
        if (GDALRasterIO(band, GF_Read, 0, fileRow, geo.columns, 1, row.data(), geo.columns, 1,
                         GDT_Float64, 0, 0) != CE_None)
            fail(path,
                 "cannot read row " + std::to_string(fileRow + 1) + ": " + CPLGetLastErrorMsg());
        const int southRow = southUp ? fileRow : geo.rows - 1 - fileRow;
        float* out = heights.data() + std::size_t(southRow) * std::size_t(geo.columns);
        for (int c = 0; c < geo.columns; ++c) {
            const double v = row[std::size_t(c)];
            const bool missing = std::isnan(v) || (hasNoData && v == noData);
            // Beyond float: Heightfield::fromGrid reports the height (+-inf is not within bounds).
            out[c] = missing ? std::numeric_limits<float>::quiet_NaN()
                             : float(std::clamp(v, -1e30, 1e30));
        }
    }
    return heights;
}

} // namespace

std::string crsName(const std::string& wkt) {
    // WKT starts with the system's kind and its quoted name: PROJCS["CH1903+ / LV95", ...
    const std::size_t open = wkt.find("[\""), close = wkt.find('"', open + 2);
    if (open == std::string::npos || close == std::string::npos) return wkt.substr(0, 40);
    return wkt.substr(open + 2, close - open - 2);
}

Georeference readDemGeoreference(const std::string& path) {
    const Dataset d = openRaster(path);
    return georeferenceOf(d.get(), path);
}

Dem readDem(const std::string& path, NoDataPolicy noData) {
    Dem dem;
    if (isEsriAscii(path)) {
        // Firn's reader: its messages name the line of the file. GDAL adds the CRS of the .prj.
        dem.heights = Heightfield::readEsriAscii(path, noData);
        const Heightfield& h = dem.heights;
        dem.geo = Georeference{h.x0() - 0.5 * h.cellSize(),
                               h.z0() - 0.5 * h.cellSize(),
                               h.cellSize(),
                               h.columns(),
                               h.rows(),
                               readDemGeoreference(path).crsWkt};
        return dem;
    }
    const Dataset d = openRaster(path);
    dem.geo = georeferenceOf(d.get(), path);
    const Georeference& g = dem.geo;
    if (g.columns < 2 || g.rows < 2 || double(g.columns) * double(g.rows) > kMaxCells)
        fail(path, "has " + std::to_string(g.columns) + " x " + std::to_string(g.rows) +
                       " cells: Firn reads 2 x 2 up to " + number(kMaxCells) +
                       " cells (resample it with gdalwarp -tr)");
    double t[6];
    GDALGetGeoTransform(d.get(), t);
    std::vector<float> heights = readHeights(d.get(), g, path, t[5] > 0.0);
    dem.heights =
        Heightfield::fromGrid(g.columns, g.rows, g.west + 0.5 * g.cell, g.south + 0.5 * g.cell,
                              g.cell, std::move(heights), path, noData);
    return dem;
}

} // namespace firn
