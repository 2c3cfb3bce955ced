// Terrain export (terrain_export.h): terrain.obj and the level set terrain.vdb. Both are written
// through writeFileAtomic, the VDB from an in-memory archive, so they appear only complete.
#include <firn/gis.h>
#include <firn/io.h>
#include <firn/terrain_export.h>

#include "vdb_file.h"

#include <openvdb/io/Archive.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/Prune.h>
#include <openvdb/tools/SignedFloodFill.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <sstream>
#include <system_error>

namespace firn {
namespace {

constexpr double kBandVoxels = 3.0;   // narrow band half width of the level set
constexpr double kMaxReachSizes = 10; // travel allowance, in sizes of the release
constexpr double kProfileMargin = 0.1;
constexpr double kWidth2d = 0.2; // extruded width of a 2D terrain, fraction of its x extent
constexpr double kMaxObjCells = 512.0 * 512.0;
constexpr double kMaxLevelSetColumns = 1024.0 * 1024.0;

/// Horizontal bounding box of the bodies at t = 0 (x, and z in 3D).
TerrainExtent bodiesBox(const SceneDesc& scene) {
    constexpr double inf = std::numeric_limits<double>::infinity();
    TerrainExtent box{inf, -inf, inf, -inf};
    auto add = [&box](double x0, double x1, double z0, double z1) {
        box.x0 = std::min(box.x0, x0), box.x1 = std::max(box.x1, x1);
        box.z0 = std::min(box.z0, z0), box.z1 = std::max(box.z1, z1);
    };
    for (const BodyDesc& b : scene.bodies) {
        if (b.shape == BodyShape::Box) add(b.min[0], b.max[0], b.min[2], b.max[2]);
        if (b.shape == BodyShape::Sphere)
            add(b.center[0] - b.radius, b.center[0] + b.radius, b.center[2] - b.radius,
                b.center[2] + b.radius);
        if (b.shape == BodyShape::Layer) add(b.xRange[0], b.xRange[1], b.zRange[0], b.zRange[1]);
    }
    if (scene.bodies.empty()) box = {-0.5, 0.5, -0.5, 0.5}; // nothing moves: a token patch
    return box;
}

/// Distance a body could cover in the run, falling freely from its initial velocity.
double freeFallReach(const SceneDesc& scene) {
    const auto& g = scene.simulation.gravity;
    const double gravity = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
    double speed = 0.0;
    for (const BodyDesc& b : scene.bodies) {
        const auto& v = b.velocity;
        speed = std::max(speed, std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]));
    }
    const double t = scene.simulation.endTime;
    return speed * t + 0.5 * gravity * t * t;
}

float sdf(const std::vector<Collider>& colliders, const Vec3f& p) {
    float d = std::numeric_limits<float>::max();
    for (const Collider& c : colliders) d = std::min(d, c.signedDistance(p));
    return d;
}

void appendf(std::string& out, const char* format, double a, double b, double c) {
    char line[128];
    const int n = std::snprintf(line, sizeof line, format, a, b, c);
    out.append(line, std::size_t(std::max(n, 0)));
}

/// Samples per axis of a regular grid over [lo, hi] at about `spacing` (at least one cell).
int cellsAlong(double lo, double hi, double spacing) {
    return std::max(1, int(std::ceil((hi - lo) / spacing - 1e-9)));
}

/// Running minimum and maximum over a window of +-r samples along one axis of an nx x nz array
/// (index i * nz + k), along x or along z.
void windowMinMax(std::vector<float>& lo, std::vector<float>& hi, int nx, int nz, int r,
                  bool alongX) {
    const std::vector<float> lo0 = lo, hi0 = hi;
    for (int i = 0; i < nx; ++i)
        for (int k = 0; k < nz; ++k) {
            float a = lo0[i * nz + k], b = hi0[i * nz + k];
            for (int s = -r; s <= r; ++s) {
                const int ii = alongX ? std::clamp(i + s, 0, nx - 1) : i;
                const int kk = alongX ? k : std::clamp(k + s, 0, nz - 1);
                a = std::min(a, lo0[ii * nz + kk]), b = std::max(b, hi0[ii * nz + kk]);
            }
            lo[i * nz + k] = a, hi[i * nz + k] = b;
        }
}

/// The level set's voxels: for each column of the extent, every voxel within the band, found
/// between the lowest and highest ground heights over the columns that can hold its nearest
/// surface point (those within the band horizontally, and one more for the slopes between).
openvdb::FloatGrid::Ptr sampleLevelSet(const std::vector<Collider>& colliders,
                                       const TerrainExtent& e, double voxelSize) {
    const double h = voxelSize, band = kBandVoxels * h;
    const int r = int(kBandVoxels) + 1;
    const int i0 = int(std::floor(e.x0 / h)) - r, i1 = int(std::ceil(e.x1 / h)) + r;
    const int k0 = int(std::floor(e.z0 / h)) - r, k1 = int(std::ceil(e.z1 / h)) + r;
    const int nx = i1 - i0 + 1, nz = k1 - k0 + 1;
    std::vector<float> lo(std::size_t(nx) * nz), hi;
    for (int i = 0; i < nx; ++i)
        for (int k = 0; k < nz; ++k)
            lo[i * nz + k] = groundHeightAt(colliders, float((i0 + i) * h), float((k0 + k) * h));
    hi = lo;
    windowMinMax(lo, hi, nx, nz, r, true);
    windowMinMax(lo, hi, nx, nz, r, false);

    auto grid = openvdb::FloatGrid::create(float(band));
    grid->setTransform(openvdb::math::Transform::createLinearTransform(h));
    auto acc = grid->getAccessor();
    // The band of column (i, k): voxel rows from bandBottom to bandTop.
    const auto bandBottom = [&](int i, int k) { return int(std::floor(lo[i * nz + k] / h)) - r; };
    const auto bandTop = [&](int i, int k) { return int(std::ceil(hi[i * nz + k] / h)) + r; };
    for (int i = r; i < nx - r; ++i)
        for (int k = r; k < nz - r; ++k) {
            for (int j = bandBottom(i, k); j <= bandTop(i, k); ++j) {
                const Vec3f p(float((i0 + i) * h), float(j * h), float((k0 + k) * h));
                const float d = sdf(colliders, p);
                if (std::abs(d) < band) acc.setValue(openvdb::Coord(i0 + i, j, k0 + k), d);
            }
        }
    openvdb::tools::signedFloodFill(grid->tree());
    // The ground is a height field: whatever lies below its column's band is inside.
    // signedFloodFill signs a tree node that holds no band voxel from its neighbours in scan
    // order, and the tree has no node at all where no band voxel is near: both once left a box
    // below the run-out outside, which firn render drew as sky under a 2D run's ground (and a
    // mesher would have drawn its walls). So: a fill below the lowest band, as deep as the
    // terrain is high and wide (what a camera framing it sees), then every inactive value
    // (voxel or tile) below the band of each sampled column it spans is set inside.
    int lowestBand = std::numeric_limits<int>::max();
    int highestBand = std::numeric_limits<int>::min();
    for (int i = r; i < nx - r; ++i)
        for (int k = r; k < nz - r; ++k) {
            lowestBand = std::min(lowestBand, bandBottom(i, k));
            highestBand = std::max(highestBand, bandTop(i, k));
        }
    if (lowestBand <= highestBand) {
        // Widened to whole leaves (8 voxels) across, so that the box is tiles, not leaves.
        const auto leafFloor = [](int v) { return v & ~7; };
        const int depth = highestBand - lowestBand + std::max(nx, nz);
        grid->tree().fill(
            openvdb::CoordBBox(
                openvdb::Coord(leafFloor(i0 + r), leafFloor(lowestBand - depth), leafFloor(k0 + r)),
                openvdb::Coord(leafFloor(i0 + nx - r - 1) + 7, lowestBand - 1,
                               leafFloor(k0 + nz - r - 1) + 7)),
            -float(band), false);
    }
    for (auto it = grid->tree().beginValueOff(); it; ++it) {
        if (*it < 0.f) continue;
        const openvdb::CoordBBox b = it.getBoundingBox();
        const int ia = std::max(b.min().x() - i0, r), ib = std::min(b.max().x() - i0, nx - r - 1);
        const int ka = std::max(b.min().z() - k0, r), kb = std::min(b.max().z() - k0, nz - r - 1);
        if (ia > ib || ka > kb) continue; // outside the sampled columns: nothing known
        int lowest = std::numeric_limits<int>::max();
        for (int i = ia; i <= ib; ++i)
            for (int k = ka; k <= kb; ++k) lowest = std::min(lowest, bandBottom(i, k));
        if (b.max().y() < lowest) it.setValue(-float(band));
    }
    // Uniform nodes become tiles. Not pruneLevelSet: it signs a node without band voxels by its
    // first value, and would turn the fill's node back outside.
    openvdb::tools::prune(grid->tree());
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    grid->setName("surface");
    return grid;
}

} // namespace

TerrainExtent terrainExtent(const SceneDesc& scene) {
    // A DEM is the ground the user drew: all of it (exportSpacing bounds the cells).
    for (const TerrainDesc& t : scene.terrains)
        if (t.shape == TerrainShape::Heightfield) {
            const Georeference g = readDemGeoreference(t.file);
            const double west = g.west - t.fileOrigin[0], south = g.south - t.fileOrigin[2];
            return TerrainExtent{west, west + g.cell * g.columns, south, south + g.cell * g.rows};
        }
    const bool is2d = scene.simulation.dimension == 2;
    const TerrainExtent box = bodiesBox(scene);
    const double size = std::max(box.x1 - box.x0, is2d ? 0.0 : box.z1 - box.z0);
    const double fall = freeFallReach(scene), reach = std::min(fall, kMaxReachSizes * size);
    TerrainExtent e{box.x0 - reach, box.x1 + reach, box.z0 - reach, box.z1 + reach};

    double px0 = std::numeric_limits<double>::infinity(), px1 = -px0;
    for (const TerrainDesc& t : scene.terrains)
        if (t.shape == TerrainShape::Profile && !t.points.empty())
            px0 = std::min(px0, t.points.front()[0]), px1 = std::max(px1, t.points.back()[0]);
    if (px0 < px1) {
        // Along x a profile is the path the user drew, as a DEM is: all of it (plus a margin) that
        // a free fall could reach, without the cap in release sizes, which stopped scenes/path2d's
        // ground 160 m short of its deposit.
        const double margin = kProfileMargin * (px1 - px0);
        e.x0 = std::min(box.x0, std::max(box.x0 - fall, px0 - margin));
        e.x1 = std::max(box.x1, std::min(box.x1 + fall, px1 + margin));
    }
    if (is2d) {
        const double w = kWidth2d * (e.x1 - e.x0);
        e.z0 = -0.5 * w, e.z1 = 0.5 * w;
    }
    return e;
}

double exportSpacing(const TerrainExtent& e, double dx, double maxCells) {
    auto cells = [&](double s) {
        return double(cellsAlong(e.x0, e.x1, s)) * double(cellsAlong(e.z0, e.z1, s));
    };
    int factor = std::max(1, int(std::floor(std::sqrt(cells(dx) / maxCells))));
    while (cells(factor * dx) > maxCells) ++factor;
    return factor * dx;
}

float groundHeightAt(const std::vector<Collider>& colliders, float x, float z) {
    float h = -std::numeric_limits<float>::infinity();
    for (const Collider& c : colliders) h = std::max(h, c.heightAt(x, z));
    return h;
}

void writeTerrainObj(const std::string& path, const std::vector<Collider>& colliders,
                     const TerrainExtent& e, double spacing, const std::string& comment,
                     const Vec3d& origin) {
    const int nx = cellsAlong(e.x0, e.x1, spacing), nz = cellsAlong(e.z0, e.z1, spacing);
    const double sx = (e.x1 - e.x0) / nx, sz = (e.z1 - e.z0) / nz;
    // Written in pieces of about a megabyte: a DEM's mesh is tens of megabytes, more than the
    // rest of a small run holds.
    AtomicFileWriter file(path);
    constexpr std::size_t kPiece = std::size_t(1) << 20;
    std::string out = "# Firn terrain: ground height field, y up, metres\n";
    auto flush = [&](std::size_t atLeast) {
        if (out.size() < atLeast) return;
        file.write(out);
        out.clear();
    };
    std::istringstream lines(comment);
    for (std::string line; std::getline(lines, line);) out += "# " + line + "\n";
    char header[160];
    std::snprintf(header, sizeof header, "# %d x %d cells of %.6g m x %.6g m\n", nx, nz, sx, sz);
    out += header;
    out += "o terrain\n";
    auto height = [&colliders](double x, double z) {
        return double(groundHeightAt(colliders, float(x), float(z)));
    };
    // Vertices row by row along z, then one normal per vertex from central differences.
    for (int i = 0; i <= nx; ++i)
        for (int k = 0; k <= nz; ++k) {
            const double x = e.x0 + i * sx, z = e.z0 + k * sz;
            appendf(out, "v %.12g %.12g %.12g\n", x + origin[0], height(x, z) + origin[1],
                    z + origin[2]);
            flush(kPiece);
        }
    for (int i = 0; i <= nx; ++i)
        for (int k = 0; k <= nz; ++k) {
            const double x = e.x0 + i * sx, z = e.z0 + k * sz;
            const double hx = (height(x + sx, z) - height(x - sx, z)) / (2 * sx);
            const double hz = (height(x, z + sz) - height(x, z - sz)) / (2 * sz);
            const double len = std::sqrt(1 + hx * hx + hz * hz);
            appendf(out, "vn %.6g %.6g %.6g\n", -hx / len, 1 / len, -hz / len);
            flush(kPiece);
        }
    // OBJ indices are 1-based; vertex and normal indices coincide. Counter-clockwise seen from
    // above, so that the faces' own normals point up as well.
    auto index = [nz](int i, int k) { return i * (nz + 1) + k + 1; };
    char line[160];
    for (int i = 0; i < nx; ++i)
        for (int k = 0; k < nz; ++k) {
            const int a = index(i, k), b = index(i, k + 1), c = index(i + 1, k + 1),
                      d = index(i + 1, k);
            const int n = std::snprintf(line, sizeof line,
                                        "f %d//%d %d//%d %d//%d\n"
                                        "f %d//%d %d//%d %d//%d\n",
                                        a, a, b, b, c, c, a, a, c, c, d, d);
            out.append(line, std::size_t(n));
            flush(kPiece);
        }
    flush(0);
    file.commit();
}

void writeTerrainLevelSet(const std::string& path, const std::vector<Collider>& colliders,
                          const TerrainExtent& extent, double voxelSize, double frameRate,
                          const Vec3d& origin) {
    openvdb::initialize();
    const openvdb::FloatGrid::Ptr grid = sampleLevelSet(colliders, extent, voxelSize);
    if (origin != Vec3d{0.0, 0.0, 0.0}) {
        grid->transform().postTranslate(openvdb::Vec3d(origin[0], origin[1], origin[2]));
        grid->insertMeta("firn_frame_origin",
                         openvdb::Vec3DMetadata(openvdb::Vec3d(origin[0], origin[1], origin[2])));
    }
    grid->setCreator("firn");
    grid->insertMeta("time", openvdb::DoubleMetadata(0.0));
    grid->insertMeta("frame", openvdb::Int32Metadata(0));
    grid->insertMeta("frame_rate", openvdb::DoubleMetadata(frameRate));
    writeVdbFileAtomic(path, {grid});
}

void exportTerrain(const SceneDesc& sceneIn, const std::vector<Collider>& colliders,
                   const std::string& outDir) {
    const SceneDesc scene = toLocalFrame(sceneIn); // the colliders' frame
    const std::string obj = outDir + "/terrain.obj", vdb = outDir + "/terrain.vdb";
    const TerrainExtent e = terrainExtent(scene);
    const float centre =
        groundHeightAt(colliders, float(0.5 * (e.x0 + e.x1)), float(0.5 * (e.z0 + e.z1)));
    if (!std::isfinite(centre)) { // no ground to draw: leave no stale terrain of an earlier run
        for (const std::string& path : {obj, vdb}) {
            std::error_code ec;
            if (!std::filesystem::remove(path, ec) && ec)
                throw IoError("cannot remove old " + path + ": " + ec.message());
        }
        return;
    }
    std::ostringstream comment;
    comment << "scene " << scene.path << ", extent x [" << e.x0 << ", " << e.x1 << "], z [" << e.z0
            << ", " << e.z1 << "]\n";
    if (scene.simulation.dimension == 2)
        comment << "2D run: the x-y ground line extruded across z, width 0.2 x extent\n";
    const double dx = scene.grid.dx;
    writeTerrainObj(obj, colliders, e, exportSpacing(e, dx, kMaxObjCells), comment.str(),
                    scene.frameOrigin);
    writeTerrainLevelSet(vdb, colliders, e, exportSpacing(e, dx, kMaxLevelSetColumns),
                         scene.simulation.frameRate, scene.frameOrigin);
}

} // namespace firn
