// GIS inputs: DEM rasters through GDAL, release areas from vector files, the local frame.
#include "test_util.h"

#include "firn_test_paths.h"

#include <firn/collider.h>
#include <firn/gis.h>
#include <firn/peak_fields.h>
#include <firn/render.h>
#include <firn/run.h>

#include <catch2/catch.hpp>
#include <cpl_conv.h>
#include <gdal.h>
#include <ogr_srs_api.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

using namespace firn;

namespace {

/// A GeoTIFF of `columns` x `rows` cells of `cell` m, north-west corner (west, north), heights
/// height(x, y) at cell centres in the file's (easting, northing), CRS EPSG:2056 (Swiss LV95).
template <typename Height>
void writeGeoTiff(const std::string& path, int columns, int rows, double west, double north,
                  double cell, Height height, double noData = std::nan("")) {
    GDALAllRegister();
    GDALDriverH driver = GDALGetDriverByName("GTiff");
    REQUIRE(driver != nullptr);
    GDALDatasetH d = GDALCreate(driver, path.c_str(), columns, rows, 1, GDT_Float32, nullptr);
    REQUIRE(d != nullptr);
    double t[6] = {west, cell, 0.0, north, 0.0, -cell};
    GDALSetGeoTransform(d, t);
    OGRSpatialReferenceH srs = OSRNewSpatialReference(nullptr);
    OSRImportFromEPSG(srs, 2056);
    char* wkt = nullptr;
    OSRExportToWkt(srs, &wkt);
    GDALSetProjection(d, wkt);
    CPLFree(wkt);
    OSRDestroySpatialReference(srs);
    GDALRasterBandH band = GDALGetRasterBand(d, 1);
    if (!std::isnan(noData)) GDALSetRasterNoDataValue(band, noData);
    std::vector<float> row(static_cast<std::size_t>(columns));
    for (int r = 0; r < rows; ++r) {
        for (int c = 0; c < columns; ++c)
            row[std::size_t(c)] = float(height(west + (c + 0.5) * cell, north - (r + 0.5) * cell));
        REQUIRE(GDALRasterIO(band, GF_Write, 0, r, columns, 1, row.data(), columns, 1, GDT_Float32,
                             0, 0) == CE_None);
    }
    GDALClose(d);
}

/// A GeoJSON FeatureCollection of polygons (rings of (easting, northing)), each with a
/// "thickness" attribute (omitted where NaN).
std::string geoJson(const std::vector<std::vector<std::vector<std::array<double, 2>>>>& polygons,
                    const std::vector<double>& thickness) {
    std::string out = "{\"type\": \"FeatureCollection\", \"features\": [\n";
    char number[64];
    for (std::size_t f = 0; f < polygons.size(); ++f) {
        out += std::string(f ? ",\n" : "") + "{\"type\": \"Feature\", \"properties\": {";
        if (!std::isnan(thickness[f])) {
            std::snprintf(number, sizeof number, "\"thickness\": %.17g", thickness[f]);
            out += number;
        }
        out += "}, \"geometry\": {\"type\": \"Polygon\", \"coordinates\": [";
        for (std::size_t r = 0; r < polygons[f].size(); ++r) {
            out += r ? ", [" : "[";
            for (std::size_t i = 0; i < polygons[f][r].size(); ++i) {
                std::snprintf(number, sizeof number, "%s[%.17g, %.17g]", i ? ", " : "",
                              polygons[f][r][i][0], polygons[f][r][i][1]);
                out += number;
            }
            out += "]";
        }
        out += "]}}";
    }
    return out + "\n]}\n";
}

std::vector<std::array<double, 2>> square(double x0, double z0, double size) {
    return {{x0, z0}, {x0 + size, z0}, {x0 + size, z0 + size}, {x0, z0 + size}, {x0, z0}};
}

} // namespace

TEST_CASE("A GeoTIFF DEM is read with its georeference and CRS", "[gis]") {
    test::TempDir dir("firn-gis-tif");
    const std::string path = dir.path() + "/dem.tif";
    // A plane rising 0.5 m per m to the north, 12 x 8 cells of 5 m, NW corner (2600000, 1200040).
    writeGeoTiff(path, 12, 8, 2600000.0, 1200040.0, 5.0,
                 [](double, double y) { return 1000.0 + 0.5 * (y - 1200000.0); });
    const Dem dem = readDem(path, NoDataPolicy::Error);
    CHECK(dem.geo.columns == 12);
    CHECK(dem.geo.rows == 8);
    CHECK(dem.geo.cell == 5.0);
    CHECK(dem.geo.west == 2600000.0);
    CHECK(dem.geo.south == 1200000.0);
    CHECK(dem.geo.crsWkt.find("CH1903+") != std::string::npos);
    // Heights at cell centres, rows from the south: the south-west cell's centre is 2.5 m north.
    const Heightfield local = dem.heights.shiftedBy(2600000.0, 1200000.0);
    CHECK(local.heightAt(2.5f, 2.5f) == Approx(1001.25).epsilon(1e-7));
    CHECK(local.heightAt(30.f, 20.f) == Approx(1010.0).epsilon(1e-7));
    float dhdx = 0.f, dhdz = 0.f;
    local.gradientAt(30.f, 20.f, dhdx, dhdz);
    CHECK(dhdx == Approx(0.0).margin(1e-6));
    CHECK(dhdz == Approx(0.5).epsilon(1e-6));
}

TEST_CASE("DEM NODATA cells: an error that names them, or filled on request", "[gis]") {
    test::TempDir dir("firn-gis-nodata");
    const std::string path = dir.path() + "/holes.tif";
    // Two NODATA cells: row 2 column 3 (the first, in reading order) and row 3 column 3.
    writeGeoTiff(
        path, 5, 4, 0.0, 20.0, 5.0,
        [](double x, double y) {
            const bool hole = x > 10.0 && x < 15.0 && y > 5.0 && y < 15.0;
            return hole ? -9999.0 : 100.0 + x;
        },
        -9999.0);
    REQUIRE_THROWS_WITH(readDem(path, NoDataPolicy::Error),
                        path + ": error: heightfield: 2 NODATA cells (the first at row 2, column "
                               "3): fill the DEM first, or set nodata = \"fill\" on the terrain");
    const Dem filled = readDem(path, NoDataPolicy::Fill);
    CHECK(filled.heights.filledCells() == 2);
    // Each hole cell takes the mean of its valid 4-neighbours: west 107.5, east 117.5, and one
    // of north/south; on a plane in x that is the plane's own 112.5.
    CHECK(filled.heights.cell(2, 1) == Approx(112.5).epsilon(1e-6));
    CHECK(filled.heights.cell(2, 2) == Approx(112.5).epsilon(1e-6));
}

TEST_CASE("A rotated or non-square DEM is refused with what to do", "[gis]") {
    test::TempDir dir("firn-gis-rot");
    const std::string path = dir.path() + "/rot.tif";
    writeGeoTiff(path, 4, 4, 0.0, 20.0, 5.0, [](double, double) { return 1.0; });
    GDALDatasetH d = GDALOpen(path.c_str(), GA_Update);
    double t[6] = {0.0, 5.0, 1.0, 20.0, 0.0, -5.0};
    GDALSetGeoTransform(d, t);
    GDALClose(d);
    REQUIRE_THROWS_WITH(readDem(path, NoDataPolicy::Error),
                        Catch::Contains("is rotated") && Catch::Contains("gdalwarp"));
    d = GDALOpen(path.c_str(), GA_Update);
    double u[6] = {0.0, 5.0, 0.0, 20.0, 0.0, -4.0};
    GDALSetGeoTransform(d, u);
    GDALClose(d);
    REQUIRE_THROWS_WITH(readDem(path, NoDataPolicy::Error),
                        Catch::Contains("has cells of 5 x 4 m") && Catch::Contains("square"));
    REQUIRE_THROWS_WITH(readDem(dir.path() + "/none.tif", NoDataPolicy::Error),
                        Catch::Contains("GDAL cannot read it as a raster"));
}

TEST_CASE("Release areas come from a vector file with their thickness", "[gis]") {
    test::TempDir dir("firn-gis-release");
    const std::string path = dir.path() + "/release.geojson";
    // A 10 m square with a 4 m hole (thickness 1.2), and a second square without an attribute.
    std::ofstream(path) << geoJson(
        {{square(100, 200, 10), square(103, 203, 4)}, {square(130, 200, 5)}}, {1.2, std::nan("")});
    BodyDesc body;
    body.shape = BodyShape::Polygon;
    body.footprintFile = path;
    body.thickness = 0.8; // the scene's thickness: every area
    body.footprintOrigin = {100.0, 0.0, 200.0};
    const std::vector<ReleaseArea> areas = readReleaseAreas(body);
    REQUIRE(areas.size() == 2);
    CHECK(areas[0].thickness == 0.8);
    CHECK(areas[0].contains(1.0, 1.0));
    CHECK_FALSE(areas[0].contains(5.0, 5.0)); // in the hole
    CHECK_FALSE(areas[0].contains(11.0, 1.0));
    CHECK(areas[1].contains(32.0, 2.0));
    CHECK(areas[0].xMin == 0.0);
    CHECK(areas[0].zMax == 10.0);
    // From the attribute: the first has one, the second has none.
    body.thickness = 0.0;
    REQUIRE_THROWS_WITH(readReleaseAreas(body),
                        Catch::Contains("feature 1 has no 'thickness' attribute"));
    std::ofstream(path) << geoJson({{square(100, 200, 10)}, {square(130, 200, 5)}}, {1.2, 0.7});
    const std::vector<ReleaseArea> fromAttribute = readReleaseAreas(body);
    REQUIRE(fromAttribute.size() == 2);
    CHECK(fromAttribute[0].thickness == 1.2);
    CHECK(fromAttribute[1].thickness == 0.7);
}

namespace {

/// A 3D scene on a plane DEM sloping 30 degrees down to the east (x), 60 x 30 m at 2 m cells,
/// whose south-west corner is (east, north); a 1 m release polygon in it, granular with an
/// internal friction (45 degrees) above the slope's, so that it slides as a block on Coulomb
/// ground. Written to `dir`, returned as text.
std::string slopeScene(const std::string& dir, double east, double north, double polygonWest) {
    const double slope = std::tan(30.0 * M_PI / 180.0);
    writeGeoTiff(dir + "/dem.tif", 30, 15, east, north + 30.0, 2.0,
                 [east, slope](double x, double) { return 1500.0 - slope * (x - east); });
    std::ofstream(dir + "/release.geojson")
        << geoJson({{square(east + polygonWest, north + 10.0, 8.0)}}, {1.0});
    return "[simulation]\nname = \"gis\"\ndimension = 3\nend_time = 0.2\nframe_rate = 10\n"
           "[grid]\ndx = 0.5\nparticles_per_cell = 1\n"
           "[[material]]\nname = \"sand\"\nmodel = \"granular\"\ndensity = 300\n"
           "youngs_modulus = 1.0e6\nfriction_angle = 45\n"
           "[[terrain]]\nshape = \"heightfield\"\nfile = \"dem.tif\"\nboundary = \"friction\"\n"
           "friction = 0.4\n"
           "[[body]]\nname = \"release\"\nmaterial = \"sand\"\nshape = \"polygon\"\n"
           "file = \"release.geojson\"\n";
}

} // namespace

TEST_CASE("A DEM 2 600 000 m east gives the same run as one at the origin", "[gis]") {
    test::TempDir near("firn-gis-near"), far("firn-gis-far");
    std::ofstream(near.path() + "/s.toml") << slopeScene(near.path(), 0.0, 0.0, 10.0);
    std::ofstream(far.path() + "/s.toml") << slopeScene(far.path(), 2600000.0, 1200000.0, 10.0);
    const SceneDesc a = loadScene(near.path() + "/s.toml");
    const SceneDesc b = loadScene(far.path() + "/s.toml");
    CHECK(localFrameOrigin(a) == Vec3d{0.0, 0.0, 0.0});
    CHECK(localFrameOrigin(b) == Vec3d{2600000.0, 0.0, 1200000.0});
    auto wa = buildWorld(a), wb = buildWorld(b);
    CHECK(wb->origin == Vec3d{2600000.0, 0.0, 1200000.0});
    REQUIRE(wa->particles.size() > 100);
    // 8 x 8 m at 1 m normal thickness, 1 particle per 0.125 m^3: about 512 / cos(30).
    CHECK(double(wa->particles.size()) == Approx(8.0 * 8.0 * 1.0 / 0.125).epsilon(0.15));
    test::advanceTo(*wa, 0.2);
    test::advanceTo(*wb, 0.2);
    // The local frames coincide, so the runs are the same to the bit; float positions at
    // 2.6e6 m would have resolved only 0.25 m.
    REQUIRE(wa->particles.size() == wb->particles.size());
    bool same = true;
    for (std::size_t i = 0; i < wa->particles.size(); ++i)
        same = same && wa->particles.x[i] == wb->particles.x[i];
    CHECK(same);
    // And it moved: down-slope (+x) by about a t^2 / 2 with a = g (sin 30 - 0.4 cos 30).
    double meanX0 = 0.0, meanX = 0.0;
    for (std::size_t i = 0; i < wa->particles.size(); ++i) meanX += wa->particles.x[i][0];
    meanX /= double(wa->particles.size());
    auto w0 = buildWorld(a);
    for (std::size_t i = 0; i < w0->particles.size(); ++i) meanX0 += w0->particles.x[i][0];
    meanX0 /= double(w0->particles.size());
    const double expected = 0.5 * 9.81 * (0.5 - 0.4 * std::sqrt(0.75)) * 0.04;
    CHECK(meanX - meanX0 > 0.5 * expected);
}

TEST_CASE("A release polygon outside the DEM is an error that says so", "[gis]") {
    test::TempDir dir("firn-gis-outside");
    std::ofstream(dir.path() + "/s.toml") << slopeScene(dir.path(), 0.0, 0.0, 55.0);
    const SceneDesc scene = loadScene(dir.path() + "/s.toml");
    REQUIRE_THROWS_WITH(buildWorld(scene, BuildStage::Seeded),
                        Catch::Contains("release.geojson: release area feature 0 reaches outside "
                                        "the DEM: its vertex at (63, 10) has no terrain under it"));
}

TEST_CASE("Peak rasters open in GDAL with the DEM's georeference and the known flow", "[gis]") {
    // The release slides at 2 m/s over flat, frictionless ground: a flow whose thickness,
    // speed and pressure are known in every cell it covers.
    test::TempDir dir("firn-gis-rasters");
    std::string text = slopeScene(dir.path(), 2600000.0, 1200000.0, 10.0);
    writeGeoTiff(dir.path() + "/dem.tif", 30, 15, 2600000.0, 1200030.0, 2.0,
                 [](double, double) { return 1500.0; });
    const std::string bed = "boundary = \"friction\"\nfriction = 0.4\n";
    text.replace(text.find(bed), bed.size(), "boundary = \"slip\"\n");
    std::ofstream(dir.path() + "/s.toml")
        << text << "velocity = [2.0, 0.0, 0.0]\n"
        << "[output]\nparticles = true\nvolumes = []\ncheckpoint_every_minutes = 0\n";
    SceneDesc scene = loadScene(dir.path() + "/s.toml", {"simulation.end_time=0.5"});
    RunOptions options;
    options.outDir = dir.path() + "/out";
    options.quiet = true;
    REQUIRE(runScene(scene, options).status == "ok");

    GDALAllRegister();
    GDALDatasetH dem = GDALOpen((dir.path() + "/dem.tif").c_str(), GA_ReadOnly);
    double demT[6];
    GDALGetGeoTransform(dem, demT);
    const std::string demCrs = GDALGetProjectionRef(dem);
    GDALClose(dem);
    const double u = 2.0; // m/s
    auto read = [&](const std::string& name) {
        GDALDatasetH d = GDALOpen((dir.path() + "/out/rasters/" + name).c_str(), GA_ReadOnly);
        REQUIRE(d != nullptr);
        double t[6];
        REQUIRE(GDALGetGeoTransform(d, t) == CE_None);
        for (int k = 0; k < 6; ++k) CHECK(t[k] == Approx(demT[k]).margin(1e-6));
        CHECK(GDALGetRasterXSize(d) == 30);
        CHECK(GDALGetRasterYSize(d) == 15);
        OGRSpatialReferenceH srs = OSRNewSpatialReference(GDALGetProjectionRef(d));
        OGRSpatialReferenceH expected = OSRNewSpatialReference(demCrs.c_str());
        CHECK(OSRIsSame(srs, expected));
        OSRDestroySpatialReference(srs);
        OSRDestroySpatialReference(expected);
        std::vector<float> v(30 * 15);
        REQUIRE(GDALRasterIO(GDALGetRasterBand(d, 1), GF_Read, 0, 0, 30, 15, v.data(), 30, 15,
                             GDT_Float32, 0, 0) == CE_None);
        GDALClose(d);
        return v;
    };
    // Cell (column 7, row 7 from the north): east 14-16 m, north 14-16 m of the corner, inside
    // the 8 x 8 m release (10-18 m) all run long.
    const std::size_t inner = 7 * 30 + 7;
    const std::vector<float> pft = read("pft.tif"), pfv = read("pfv.tif"), ppr = read("ppr.tif");
    const std::vector<float> dft = read("dft.tif"), pftAsc = read("pft.asc");
    // 1 m released; the particles (0.5 m apart) spread over the 2 m cells bilinearly: 5 %.
    CHECK(pft[inner] == Approx(1.0).epsilon(0.05));
    CHECK(dft[inner] == Approx(1.0).epsilon(0.05));
    // The speed: 2 m/s plus the small vertical ringing of a block landing stress-free (2 %).
    CHECK(pfv[inner] == Approx(u).epsilon(0.02));
    // Pressure rho u^2 in kPa: 300 kg/m^3 x 4 m^2/s^2 = 1.2 kPa (the cell's density: 4 %).
    CHECK(ppr[inner] == Approx(300.0 * u * u / 1000.0).epsilon(0.04));
    CHECK(pftAsc[inner] == Approx(pft[inner]).epsilon(1e-6));
    // Snow never reached the far west corner (up-slope of the release).
    CHECK(pft[14 * 30] == 0.f);
    CHECK(std::filesystem::exists(dir.path() + "/out/rasters/pft.prj"));

    // firn report draws the maps over the DEM's hillshade.
    const std::string report =
        std::string(FIRN_BINARY) + " report " + dir.path() + "/out --quiet > /dev/null 2>&1";
    CHECK(std::system(report.c_str()) == 0);
    CHECK(std::filesystem::exists(dir.path() + "/out/report/hazard_maps.png"));
    std::ifstream page(dir.path() + "/out/report/report.html");
    const std::string html((std::istreambuf_iterator<char>(page)), {});
    CHECK(html.find("hazard_maps.png") != std::string::npos);

    // The caches and the summary are in the DEM's coordinates too.
    std::ifstream summary(dir.path() + "/out/summary.json");
    const std::string summaryText((std::istreambuf_iterator<char>(summary)), {});
    CHECK(summaryText.find("\"runout_x\": 26000") != std::string::npos);
    std::ifstream obj(dir.path() + "/out/terrain.obj");
    std::string line;
    while (std::getline(obj, line) && line.rfind("v ", 0) != 0) {
    }
    CHECK(line.rfind("v 2600000 ", 0) == 0);
}

TEST_CASE("GIS scene keys: polygon bodies, nodata and rasters are checked where they are read",
          "[gis][scene]") {
    test::TempDir dir("firn-gis-keys");
    std::ofstream(dir.path() + "/s.toml") << slopeScene(dir.path(), 0.0, 0.0, 10.0);
    const SceneDesc scene = loadScene(dir.path() + "/s.toml");
    REQUIRE(scene.bodies.size() == 1);
    CHECK(scene.bodies[0].shape == BodyShape::Polygon);
    CHECK(scene.bodies[0].thickness == 0.0); // from the attribute
    CHECK(scene.bodies[0].thicknessAttribute == "thickness");
    CHECK(scene.terrains[0].noData == NoDataPolicy::Error);
    CHECK(scene.output.rasters);
    // The as-run scene names the release file absolutely, as it does the DEM.
    CHECK(scene.resolvedToml.find(dir.path() + "/release.geojson") != std::string::npos);
    const std::string path = dir.path() + "/s.toml";
    std::string text = slopeScene(dir.path(), 0.0, 0.0, 10.0);
    text.replace(text.find("friction = 0.4\n"), 15, "friction = 0.4\nnodata = \"zero\"\n");
    std::ofstream(dir.path() + "/bad.toml") << text;
    REQUIRE_THROWS_WITH(loadScene(dir.path() + "/bad.toml"),
                        Catch::Contains("terrain 1: nodata") && Catch::Contains("fill"));
    // Voellmy's xi belongs to boundary "voellmy" only, and must be > 0.
    text = slopeScene(dir.path(), 0.0, 0.0, 10.0);
    text.replace(text.find("friction = 0.4\n"), 15, "friction = 0.4\nturbulence = 1000.0\n");
    std::ofstream(dir.path() + "/bad.toml") << text;
    REQUIRE_THROWS_WITH(loadScene(dir.path() + "/bad.toml"),
                        Catch::Contains("terrain 1: turbulence") &&
                            Catch::Contains("boundary \"friction\""));
    text.replace(text.find("\"friction\"\n"), 11, "\"voellmy\"\n");
    std::ofstream(dir.path() + "/bad.toml") << text;
    const SceneDesc voellmy = loadScene(dir.path() + "/bad.toml");
    CHECK(voellmy.terrains[0].boundary == Boundary::Voellmy);
    CHECK(voellmy.terrains[0].turbulence == 1000.0);
    CHECK(voellmy.terrains[0].friction == 0.4);
    // A named terrain can be calibrated from the command line.
    text.replace(text.find("shape = \"heightfield\""), 21,
                 "name = \"bed\"\nshape = \"heightfield\"");
    std::ofstream(dir.path() + "/bed.toml") << text;
    const SceneDesc calibrated = loadScene(
        dir.path() + "/bed.toml", {"terrain.bed.friction=0.25", "terrain.bed.turbulence=3000.0"});
    CHECK(calibrated.terrains[0].friction == 0.25);
    CHECK(calibrated.terrains[0].turbulence == 3000.0);
    // samosAT: AvaFrame's calibration by default, its coefficients only with it, xi not.
    REQUIRE_THROWS_WITH(loadScene(dir.path() + "/bed.toml", {"terrain.bed.boundary=\"samosat\""}),
                        Catch::Contains("terrain \"bed\": turbulence") &&
                            Catch::Contains("boundary \"samosat\""));
    REQUIRE_THROWS_WITH(loadScene(dir.path() + "/bed.toml", {"terrain.bed.samosat_b=4.0"}),
                        Catch::Contains("terrain \"bed\": samosat_b") &&
                            Catch::Contains("boundary \"voellmy\""));
    text.replace(text.find("turbulence = 1000.0\n"), 20, "");
    std::ofstream(dir.path() + "/samosat.toml") << text;
    const SceneDesc samosat =
        loadScene(dir.path() + "/samosat.toml",
                  {"terrain.bed.boundary=\"samosat\"", "terrain.bed.samosat_r=0.1"});
    CHECK(samosat.terrains[0].boundary == Boundary::SamosAT);
    CHECK(samosat.terrains[0].samosatR == 0.1);
    CHECK(samosat.terrains[0].samosatRs0 == 0.222);
    CHECK(samosat.terrains[0].friction == 0.4); // the file's, not the default 0.155
    REQUIRE_THROWS_WITH(loadScene(dir.path() + "/bed.toml", {"terrain.bed.turbulence=-1.0"}),
                        Catch::Contains("terrain \"bed\": turbulence"));
    REQUIRE_THROWS_WITH(loadScene(path, {"body.release.x_range=[0.0, 1.0]"}),
                        Catch::Contains("x_range") && Catch::Contains("shape \"polygon\""));
    REQUIRE_THROWS_WITH(loadScene(path, {"body.release.thickness=-1.0"}),
                        Catch::Contains("body \"release\": thickness"));
    const std::string plane =
        "[simulation]\ndimension = 3\n[[material]]\nname = \"m\"\nmodel = \"granular\"\n"
        "[[terrain]]\nshape = \"plane\"\npoint = [0, 0, 0]\n"
        "normal = [0, 1, 0]\n";
    REQUIRE_THROWS_WITH(test::sceneFromText(plane + "[output]\nrasters = true\n"),
                        Catch::Contains("output.rasters") &&
                            Catch::Contains("the scene has no heightfield terrain"));
    REQUIRE_THROWS_WITH(
        test::sceneFromText("[simulation]\ndimension = 2\n[[material]]\nmodel = \"granular\"\n"
                            "name = \"m\"\n[[body]]\nmaterial = \"m\"\n"
                            "shape = \"polygon\"\nfile = \"" +
                            dir.path() + "/release.geojson\"\n"),
        Catch::Contains("\"polygon\" needs dimension = 3"));
}

namespace {

/// The synthetic path of scenes/path3d (bench/synthetic_path.cc) at 5 m cells, rotated by
/// `degrees` about the vertical, coarse (dx 5 m), run to rest: the distance along the path
/// (from its top, m) that 99 % of the mass stays behind, and the farthest particle's.
std::pair<double, double> pathRunout(double degrees) {
    test::TempDir dir("firn-gis-path");
    const std::string command = std::string(FIRN_SYNTHETIC_PATH) + " " + dir.path() +
                                " --cell 5 --rotate " + std::to_string(degrees) + " > /dev/null";
    REQUIRE(std::system(command.c_str()) == 0);
    std::ifstream in(FIRN_SOURCE_DIR "/scenes/path3d.toml");
    std::string text((std::istreambuf_iterator<char>(in)), {});
    text.replace(text.find("path3d/dem.tif"), 14, dir.path() + "/dem.tif");
    text.replace(text.find("path3d/release.shp"), 18, dir.path() + "/release.shp");
    SceneDesc scene =
        parseScene(text, dir.path() + "/path.toml", {"grid.dx=5.0", "simulation.end_time=80.0"});
    auto w = buildWorld(scene);
    test::advanceTo(*w, 80.0);
    const double a = degrees * M_PI / 180.0, cx = 150.0, cz = 200.0;
    std::vector<double> along;
    for (std::size_t i = 0; i < w->particles.size(); ++i) {
        // Map coordinates from the path's corner, then along the (rotated) path.
        const double x = w->particles.x[i][0] + w->origin[0] - 2600000.0 - cx;
        const double z = w->particles.x[i][2] + w->origin[2] - 1200000.0 - cz;
        along.push_back(cx + std::cos(a) * x + std::sin(a) * z);
    }
    std::sort(along.begin(), along.end());
    return {along[std::size_t(0.99 * double(along.size() - 1))], along.back()};
}

} // namespace

TEST_CASE("The same release on a DEM rotated by 25 degrees runs out as far (V11)",
          "[gis][path][slow]") {
    const auto straight = pathRunout(0.0), rotated = pathRunout(25.0);
    INFO("runout along the path: 99 % of the mass "
         << straight.first << " m (rotated " << rotated.first << " m), farthest " << straight.second
         << " m (" << rotated.second << " m)");
    // It flowed: from the release (s 50-250 m) well into the path.
    CHECK(straight.first > 500.0);
    // No grid-direction bias: within one DEM cell (5 m), as V11 asks.
    CHECK(std::abs(rotated.first - straight.first) < 5.0);
    CHECK(std::abs(rotated.second - straight.second) < 5.0);
}

TEST_CASE("Peak fields survive a checkpoint round trip", "[gis][checkpoint]") {
    test::TempDir dir("firn-gis-peaks");
    std::ofstream(dir.path() + "/s.toml") << slopeScene(dir.path(), 0.0, 0.0, 10.0);
    const SceneDesc scene = loadScene(dir.path() + "/s.toml");
    auto w = buildWorld(scene);
    const Georeference grid = peakFieldGrid(scene);
    REQUIRE(grid.columns == 30);
    PeakFields peaks(grid, w->origin, *w->colliders[0].heightfield());
    peaks.accumulate(w->particles);
    test::advanceTo(*w, 0.05);
    peaks.accumulate(w->particles);
    ByteWriter out;
    peaks.save(out);
    PeakFields loaded(grid, w->origin, *w->colliders[0].heightfield());
    ByteReader in(out.bytes().data(), out.bytes().size());
    loaded.load(in);
    CHECK(loaded.samples() == 2);
    bool same = true, any = false;
    for (int r = 0; r < grid.rows; ++r)
        for (int c = 0; c < grid.columns; ++c) {
            same = same && loaded.peakThickness(c, r) == peaks.peakThickness(c, r) &&
                   loaded.peakSpeed(c, r) == peaks.peakSpeed(c, r) &&
                   loaded.peakPressure(c, r) == peaks.peakPressure(c, r) &&
                   loaded.depositThickness(c, r) == peaks.depositThickness(c, r);
            any = any || peaks.peakSpeed(c, r) > 0.f;
        }
    CHECK(same);
    CHECK(any);
    // A checkpoint of another grid is refused, not misread.
    Georeference other = grid;
    other.columns = 10;
    PeakFields small(other, w->origin, *w->colliders[0].heightfield());
    ByteReader again(out.bytes().data(), out.bytes().size());
    CHECK_THROWS_AS(small.load(again), ByteReadError);
}

TEST_CASE("firn render draws a run on a far-off DEM as it draws the same run at the origin",
          "[gis][render]") {
    // The caches carry the local frame's origin in their transforms; a renderer that took voxel
    // (0, 0, 0) for the world's origin drew the terrain without its snow.
    auto render = [](double east, double north) {
        test::TempDir dir("firn-gis-render");
        std::ofstream(dir.path() + "/s.toml")
            << slopeScene(dir.path(), east, north, 10.0)
            << "[output]\nparticles = false\nvolumes = [\"density\", \"velocity\"]\n";
        RunOptions run;
        run.outDir = dir.path() + "/out";
        run.quiet = true;
        REQUIRE(runScene(loadScene(dir.path() + "/s.toml"), run).status == "ok");
        RenderOptions options;
        options.view.width = 160, options.view.height = 90;
        options.video = false;
        options.quiet = true;
        renderOutput(run.outDir, options);
        return readPng(run.outDir + "/render/frame.0002.png");
    };
    const Image near = render(0.0, 0.0), far = render(2600000.0, 1200000.0);
    REQUIRE(near.width == far.width);
    REQUIRE(near.rgb.size() == far.rgb.size());
    double difference = 0.0;
    for (std::size_t i = 0; i < near.rgb.size(); ++i)
        difference += std::abs(int(near.rgb[i]) - int(far.rgb[i])) / 255.0;
    const double mean = difference / double(near.rgb.size());
    INFO("mean difference per channel " << mean);
    // The same picture up to the camera's rounding at 2.6e6 m (double precision: far below a
    // pixel): measured 0. A renderer that loses the snow (the bug this guards) differs by 0.023.
    CHECK(mean < 0.002);
}

TEST_CASE("On a curved path, alpha along the flow's own path and along a given line agree",
          "[gis][path][hazard]") {
    // A valley whose floor turns 90 degrees along a quarter circle of radius 150 m about the
    // DEM's origin (east, then north), dropping 100 m over its first 180 m (a parabola, flat
    // after), with parabolic side walls. A release near its top runs around the bend and stops
    // on the floor. Measured 2026-12-07: alpha 23.83 deg along the derived path, 23.98 along the
    // line, and 127 deg along x (the farthest snow in x lies west of the crown: no angle at all).
    test::TempDir dir("firn-curved-path");
    const double east = 2600000.0, north = 1200000.0, r0 = 150.0;
    const auto floor = [&](double x, double z) {
        const double theta = std::clamp(std::atan2(z - north, x - east), 0.0, M_PI / 2.0);
        const double s = r0 * theta, r = std::hypot(x - east, z - north);
        const double drop = s < 180.0 ? 100.0 * (1.0 - s / 180.0) * (1.0 - s / 180.0) : 0.0;
        return 1500.0 + drop + 0.01 * (r - r0) * (r - r0);
    };
    writeGeoTiff(dir.path() + "/dem.tif", 52, 56, east - 40.0, north + 220.0, 5.0, floor);
    const auto onArc = [&](double radius, double deg) {
        return std::array<double, 2>{east + radius * std::cos(deg * M_PI / 180.0),
                                     north + radius * std::sin(deg * M_PI / 180.0)};
    };
    std::ofstream(dir.path() + "/release.geojson")
        << geoJson({{{onArc(138.0, 2.0), onArc(162.0, 2.0), onArc(162.0, 14.0), onArc(138.0, 14.0),
                      onArc(138.0, 2.0)}}},
                   {2.0});
    std::string line = "{\"type\": \"FeatureCollection\", \"features\": [{\"type\": \"Feature\", "
                       "\"properties\": {}, \"geometry\": {\"type\": \"LineString\", "
                       "\"coordinates\": [";
    for (int deg = -5; deg <= 100; deg += 5) {
        const auto p = onArc(r0, deg);
        line += (deg > -5 ? ", [" : "[") + std::to_string(p[0]) + ", " + std::to_string(p[1]) + "]";
    }
    std::ofstream(dir.path() + "/path.geojson") << line << "]}}]}\n";
    const std::string scene =
        "[simulation]\nname = \"curved\"\ndimension = 3\nend_time = 60.0\nframe_rate = 2\n"
        "[grid]\ndx = 2.5\nparticles_per_cell = 8\n"
        "[[material]]\nname = \"snow\"\nmodel = \"granular\"\ndensity = 300\n"
        "youngs_modulus = 1.0e5\nfriction_angle = 35\n"
        "[[terrain]]\nshape = \"heightfield\"\nfile = \"dem.tif\"\nboundary = \"friction\"\n"
        "friction = 0.4\n"
        "[[body]]\nname = \"release\"\nmaterial = \"snow\"\nshape = \"polygon\"\n"
        "file = \"release.geojson\"\n"
        "[output]\nparticles = false\nvolumes = []\ncheckpoint_every_minutes = 0\n";
    std::ofstream(dir.path() + "/derived.toml") << scene;
    std::ofstream(dir.path() + "/given.toml") << scene << "path = \"path.geojson\"\n";
    std::map<std::string, std::string> summary;
    for (const std::string name : {"derived", "given"}) {
        RunOptions options;
        options.outDir = dir.path() + "/" + name;
        options.quiet = true;
        REQUIRE(runScene(loadScene(dir.path() + "/" + name + ".toml"), options).status == "ok");
        std::ifstream in(options.outDir + "/summary.json");
        summary[name] = std::string(std::istreambuf_iterator<char>(in), {});
    }
    const auto number = [&](const std::string& name, const std::string& key) {
        const std::string& json = summary[name];
        const std::size_t at = json.find("\"" + key + "\": ");
        REQUIRE(at != std::string::npos);
        return std::stod(json.substr(at + key.size() + 4));
    };
    CHECK(summary["derived"].find("\"path_source\": \"derived\"") != std::string::npos);
    CHECK(summary["given"].find("\"path_source\": \"scene\"") != std::string::npos);
    CHECK(summary["given"].find("\"stop_reason\": \"at_rest\"") != std::string::npos);
    const double derived = number("derived", "alpha_angle_deg");
    const double given = number("given", "alpha_angle_deg");
    const double length = number("given", "runout_length");
    // What alpha along x gives: the top to the farthest snow along x (runout_x, runout_y).
    const double alongX =
        std::atan2(number("given", "release_top_y") - number("given", "runout_y"),
                   number("given", "runout_x") - number("given", "release_top_x")) *
        180.0 / M_PI;
    INFO("alpha derived " << derived << " deg, given " << given << " deg, along x " << alongX
                          << " deg; runout length along the line " << length << " m, derived "
                          << number("derived", "runout_length") << " m");
    // The bound: a derived path and a given one within 2 degrees.
    CHECK(std::abs(derived - given) < 2.0);
    // And the bend counts: the flow went past 45 degrees of it, and x alone misses the run.
    CHECK(length > r0 * M_PI / 4.0);
    CHECK(alongX > given + 5.0);
    // A path file without a line fails before the run, naming the key and the file.
    std::ofstream(dir.path() + "/bad.toml") << scene << "path = \"release.geojson\"\n";
    RunOptions options;
    options.outDir = dir.path() + "/bad";
    options.quiet = true;
    REQUIRE_THROWS_WITH(runScene(loadScene(dir.path() + "/bad.toml"), options),
                        Catch::Contains("output.path") && Catch::Contains("release.geojson") &&
                            Catch::Contains("holds no line"));
    CHECK_FALSE(std::filesystem::exists(dir.path() + "/bad/frames"));
}
