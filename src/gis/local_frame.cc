// The local frame: a scene on a DEM at eastings and northings of 1e5-1e6 m is simulated next to
// 0, where float positions resolve its snow, and written back in the DEM's coordinates.
#include <firn/gis.h>

#include <cmath>

namespace firn {

Vec3d localFrameOrigin(const SceneDesc& scene) {
    for (const TerrainDesc& t : scene.terrains) {
        if (t.shape != TerrainShape::Heightfield) continue;
        const Georeference geo = readDemGeoreference(t.file);
        // The DEM's corner in the frame the scene is in now (a scene already moved has its
        // DEM's coordinates shifted by fileOrigin).
        const double west = geo.west - t.fileOrigin[0], south = geo.south - t.fileOrigin[2];
        // Whole kilometres: the origin is a round number a user can read in the outputs.
        auto origin = [](double corner) {
            return std::abs(corner) < kLocalFrameDistance ? 0.0
                                                          : 1000.0 * std::floor(corner / 1000.0);
        };
        return Vec3d{origin(west), 0.0, origin(south)};
    }
    return Vec3d{0.0, 0.0, 0.0};
}

SceneDesc toLocalFrame(const SceneDesc& scene) {
    const Vec3d o = localFrameOrigin(scene);
    if (o == Vec3d{0.0, 0.0, 0.0}) return scene;
    SceneDesc local = scene;
    auto shift = [&o](Vec3d& p) {
        for (int a = 0; a < 3; ++a) p[a] -= o[a];
    };
    for (int a = 0; a < 3; ++a) local.frameOrigin[a] += o[a];
    for (TerrainDesc& t : local.terrains) {
        shift(t.point);
        for (auto& p : t.points) p[0] -= o[0], p[1] -= o[1];
        for (int a = 0; a < 3; ++a) t.fileOrigin[a] += o[a];
    }
    for (BodyDesc& b : local.bodies) {
        shift(b.min), shift(b.max), shift(b.center);
        b.xRange[0] -= o[0], b.xRange[1] -= o[0];
        b.zRange[0] -= o[2], b.zRange[1] -= o[2];
        for (int a = 0; a < 3; ++a) b.footprintOrigin[a] += o[a];
    }
    for (CutDesc& c : local.cuts) c.fromX -= o[0];
    // An infinite bound stays infinite.
    shift(local.simulation.domainMin);
    shift(local.simulation.domainMax);
    return local;
}

} // namespace firn
