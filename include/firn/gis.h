// GIS inputs and frames: DEM rasters through GDAL, and the local frame a scene on a real DEM is
// simulated in. A DEM's easting is the scene's x, its northing the scene's z, its elevation y.
#pragma once

#include <firn/dem.h>
#include <firn/scene.h>

#include <array>
#include <string>
#include <vector>

namespace firn {

/// Where a raster lies in its own coordinate reference system: a north-up grid of square cells.
struct Georeference {
    double west = 0.0, south = 0.0; ///< the grid's south-west corner (a cell edge), m
    double cell = 1.0;              ///< m
    int columns = 0, rows = 0;
    std::string crsWkt; ///< the reference system as WKT; empty when the file names none
};

/// A DEM as read: heights in the file's own coordinates, and its georeference.
struct Dem {
    Heightfield heights;
    Georeference geo;
};

/// Reads a DEM: an ESRI ASCII grid (.asc, any header case) with Firn's own reader, whose errors
/// name the line; any other raster GDAL reads (GeoTIFF, ...) through GDAL, band 1. The grid must
/// be north-up with square cells (gdalwarp -tr makes it so). The CRS comes from the file (an
/// .asc's .prj beside it). Throws SceneError naming the file: unreadable, rotated, NODATA cells
/// under NoDataPolicy::Error, heights or sizes beyond Heightfield's bounds.
Dem readDem(const std::string& path, NoDataPolicy noData);

/// The georeference alone (the header; no heights are read). Throws SceneError as readDem.
Georeference readDemGeoreference(const std::string& path);

/// One release area of a `shape = "polygon"` body: a polygon (outer ring and holes) in the
/// local frame's (x, z), and its release thickness normal to the slope.
struct ReleaseArea {
    std::vector<std::vector<std::array<double, 2>>> rings; ///< closed rings of (x, z), m
    double thickness = 0.0;                                ///< m
    std::string label;                                     ///< "feature 3" for messages
    double xMin = 0, xMax = 0, zMin = 0, zMax = 0;         ///< bounding box, m
    /// Even-odd rule over all rings: inside the outer ring and outside every hole.
    bool contains(double x, double z) const;
};

/// Reads the release areas of a polygon body: every polygon and multipolygon of every layer of
/// its vector file (any OGR format: shapefile, GeoPackage, GeoJSON), moved into the local frame
/// (BodyDesc::footprintOrigin). Each area's thickness is the body's `thickness` when the scene
/// gives one, else the feature's `thickness_attribute`. Throws SceneError naming the file and
/// the feature: unreadable, no polygons, a feature without a thickness, a thickness <= 0.
std::vector<ReleaseArea> readReleaseAreas(const BodyDesc& body);

/// The avalanche's path line of output.path: the first line (LineString, or a MultiLineString's
/// first part) of the file, (easting, northing) moved into the local frame by `origin` (x, z).
/// Throws SceneError naming the [output] table, the key and the file.
std::vector<std::array<double, 2>> readPathLine(const OutputDesc& output, const Vec3d& origin);

/// The name a WKT gives its reference system ("CH1903+ / LV95"), or the WKT's start.
std::string crsName(const std::string& wkt);

/// A scene coordinate this far from 0 or more (m) moves the simulation into a local frame: a
/// float resolves 1e4 m to 1 mm, 1e6 m only to 6 cm.
constexpr double kLocalFrameDistance = 1e4;

/// The local frame's origin for `scene`: the south-west corner of its first heightfield DEM,
/// rounded down to whole kilometres, where that corner lies kLocalFrameDistance or more from 0
/// along x or z; zero otherwise (and always along y: elevations stay as they are). Throws
/// SceneError when the DEM cannot be read.
Vec3d localFrameOrigin(const SceneDesc& scene);

/// The scene moved into its local frame (localFrameOrigin): every coordinate the simulation uses
/// (terrain points, DEM files, bodies, cuts, the domain) less the origin, and frameOrigin set.
/// A scene already in its frame comes back unchanged. The render camera stays in scene
/// coordinates: it looks at the caches, which are written back in them.
SceneDesc toLocalFrame(const SceneDesc& scene);

} // namespace firn
