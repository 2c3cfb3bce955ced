// Terrain export for renderers: the ground the snow flows on, written once per run next to the
// caches, as `terrain.obj` (a triangulated height field with normals) and `terrain.vdb` (a
// narrow-band level set "surface" sampled from the colliders' signed distance).
//
// The ground is the union of the scene's colliders: its height is the largest collider height,
// its signed distance the smallest collider distance (as seeding sees it, solver/setup.cc).
// Colliders without a height (vertical planes, walls) cannot be drawn as a height field and are
// left out of both files.
//
// Scenes have no domain box, so the horizontal extent is derived (terrainExtent): the bodies'
// bounding box grown by how far the snow could travel in the run, kept within the terrain's own
// x range where a profile gives one. 2D runs lie in the x-y plane at z = 0: their terrain is
// extruded across z in [-W/2, W/2] with W = 0.2 times the x extent, in both files.
#pragma once

#include <firn/collider.h>
#include <firn/scene.h>

#include <string>
#include <vector>

namespace firn {

/// Horizontal rectangle [x0, x1] x [z0, z1] over which the terrain is exported, m.
struct TerrainExtent {
    double x0 = 0, x1 = 0, z0 = 0, z1 = 0;
};

/// The extent to export for `scene`: a heightfield DEM's whole extent; else the bodies' bounding
/// box grown on every side by the distance a body could cover in free fall over the run (|v0| T + g
/// T^2 / 2), at most 10 times the box's size; along x, clipped to the profiles' x range grown by 10
/// %. 2D: the z range is
/// [-W/2, W/2], W = 0.2 (x1 - x0).
TerrainExtent terrainExtent(const SceneDesc& scene);

/// Sample spacing of an export: `dx` doubled, tripled, ... until the extent needs at most
/// `maxCells` cells on the horizontal grid, so that a large domain stays a sensible size.
double exportSpacing(const TerrainExtent& extent, double dx, double maxCells);

/// Ground height at (x, z): the largest collider height; -inf where no collider has one.
float groundHeightAt(const std::vector<Collider>& colliders, float x, float z);

/// Writes a Wavefront OBJ of the ground over `extent`: a regular grid at `spacing` (vertices on
/// the surface, normals from the height gradient), two triangles per cell facing up (+y).
/// `comment` lines go into the header. Atomic like every output. Throws IoError.
/// Vertices are written at `origin` plus the colliders' coordinates (the local frame's origin,
/// SceneDesc::frameOrigin), so that a far-off DEM's terrain is in its own coordinates.
void writeTerrainObj(const std::string& path, const std::vector<Collider>& colliders,
                     const TerrainExtent& extent, double spacing, const std::string& comment = "",
                     const Vec3d& origin = {0.0, 0.0, 0.0});

/// Writes a VDB file with one FloatGrid "surface" (GRID_LEVEL_SET): the colliders' signed
/// distance (> 0 above the ground) on voxels within 3 voxels of the surface over `extent`,
/// background 3 voxels, signs flood-filled below. Voxel (i, j, k) sits at (i, j, k) voxelSize
/// as in the volume cache. Metadata as the caches': creator "firn", time 0 and frame 0 (the
/// ground is static, so it holds for every frame), frame_rate. Blosc compressed, atomic. Throws
/// IoError.
/// The transform is translated by `origin` as for the OBJ.
void writeTerrainLevelSet(const std::string& path, const std::vector<Collider>& colliders,
                          const TerrainExtent& extent, double voxelSize, double frameRate,
                          const Vec3d& origin = {0.0, 0.0, 0.0});

/// What `firn run` calls as it prepares the output folder (with the scene in scene coordinates
/// and the colliders in its local frame, firn/gis.h): writes `outDir/terrain.obj` and
/// `outDir/terrain.vdb` for the scene's colliders. The OBJ is sampled at about dx (at most
/// 512 x 512 cells), the level set at dx (coarser when the extent would need more than
/// 1024 x 1024 columns). A scene without any collider with a height writes neither file and
/// removes those of an earlier run. Throws IoError.
void exportTerrain(const SceneDesc& scene, const std::vector<Collider>& colliders,
                   const std::string& outDir);

} // namespace firn
