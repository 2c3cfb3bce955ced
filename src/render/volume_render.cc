// `firn render`: ray marches the volume cache of a run (density, coloured by speed, failed
// fraction, eta or density) over its terrain level set, one PNG per frame, TBB-parallel over
// image rows. Every pixel depends only on the grids, so frames are identical for any thread count.
#include <firn/errors.h>
#include <firn/render.h>

#include <openvdb/io/File.h>
#include <openvdb/math/Ray.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/Morphology.h>
#include <openvdb/tools/RayIntersector.h>

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>
#include <regex>
#include <sstream>

namespace firn {
namespace {

namespace fs = std::filesystem;
using openvdb::Coord;
using openvdb::FloatGrid;
using openvdb::Vec3d;
using openvdb::Vec3fGrid;
using RayT = openvdb::math::Ray<double>;
using Sampler = openvdb::tools::BoxSampler;

/// One frame of the volume cache, with what the renderer needs from it.
struct VolumeFrameGrids {
    int frame = 0;
    double time = 0.0;
    double frameRate = 24.0;
    FloatGrid::Ptr density;
    Vec3fGrid::Ptr velocity;
    FloatGrid::Ptr failed, eta;
};

const char* gridFor(ColorBy colorBy) {
    switch (colorBy) {
    case ColorBy::Speed:
        return "velocity";
    case ColorBy::Failed:
        return "failed";
    case ColorBy::Eta:
        return "eta";
    case ColorBy::Density:
        break;
    }
    return "density";
}

/// frame number -> path of OUT_DIR/frames/volume.NNNN.vdb
std::map<int, std::string> listVolumeFrames(const std::string& outDir) {
    const fs::path dir = fs::path(outDir) / "frames";
    std::error_code error;
    if (!fs::is_directory(dir, error)) {
        throw IoError(dir.string() + ": not a folder: is " + outDir +
                      " the output folder of `firn run`?");
    }
    static const std::regex name(R"(volume\.(\d{4,})\.vdb)");
    std::map<int, std::string> frames;
    for (const auto& entry : fs::directory_iterator(dir)) {
        std::smatch m;
        const std::string file = entry.path().filename().string();
        if (std::regex_match(file, m, name)) frames[std::stoi(m[1])] = entry.path().string();
    }
    if (frames.empty()) {
        throw IoError(dir.string() + ": no volume.NNNN.vdb files (output.volumes must list at "
                                     "least \"density\")");
    }
    return frames;
}

template <typename GridT>
typename GridT::Ptr readGrid(openvdb::io::File& file, const std::string& path,
                             const std::string& name, bool required) {
    if (!file.hasGrid(name)) {
        if (!required) return nullptr;
        throw IoError(path + ": no '" + name + "' grid (add \"" + name +
                      "\" to output.volumes in the scene and run it again)");
    }
    auto grid = openvdb::gridPtrCast<GridT>(file.readGrid(name));
    if (!grid) throw IoError(path + ": grid '" + name + "' has an unexpected value type");
    return grid;
}

VolumeFrameGrids readFrame(int frame, const std::string& path, ColorBy colorBy) {
    VolumeFrameGrids f;
    f.frame = frame;
    try {
        openvdb::io::File file(path);
        file.open();
        f.density = readGrid<FloatGrid>(file, path, "density", true);
        const std::string colour = gridFor(colorBy);
        if (colour == "velocity") f.velocity = readGrid<Vec3fGrid>(file, path, colour, true);
        if (colour == "failed") f.failed = readGrid<FloatGrid>(file, path, colour, true);
        if (colour == "eta") f.eta = readGrid<FloatGrid>(file, path, colour, true);
        file.close();
    } catch (const openvdb::Exception& e) {
        throw IoError(path + ": cannot read: " + e.what());
    }
    if (auto m = f.density->getMetadata<openvdb::DoubleMetadata>("time")) f.time = m->value();
    if (auto m = f.density->getMetadata<openvdb::DoubleMetadata>("frame_rate"))
        f.frameRate = m->value();
    return f;
}

/// Value of the colour quantity at index-space point `ijk` (interpolated).
struct ColourSampler {
    ColorBy colorBy;
    openvdb::FloatGrid::ConstAccessor density;
    std::optional<Vec3fGrid::ConstAccessor> velocity;
    std::optional<FloatGrid::ConstAccessor> scalar;

    ColourSampler(const VolumeFrameGrids& f, ColorBy by)
        : colorBy(by)
        , density(f.density->getConstAccessor()) {
        if (f.velocity) velocity.emplace(f.velocity->getConstAccessor());
        if (f.failed) scalar.emplace(f.failed->getConstAccessor());
        if (f.eta) scalar.emplace(f.eta->getConstAccessor());
    }
    float rho(const Vec3d& ijk) { return Sampler::sample(density, ijk); }
    /// The colour quantity divided by the density weight it was averaged with: near the edge of
    /// the snow, trilinear weights mix in empty voxels (value 0), so the mean is renormalised by
    /// the occupied fraction.
    float value(const Vec3d& ijk) {
        switch (colorBy) {
        case ColorBy::Density:
            return rho(ijk);
        case ColorBy::Speed:
            return occupiedMean(*velocity, ijk).length();
        case ColorBy::Failed:
        case ColorBy::Eta:
            return occupiedMean(*scalar, ijk);
        }
        return 0.f;
    }
    template <typename Accessor>
    auto occupiedMean(Accessor& acc, const Vec3d& ijk) -> typename Accessor::ValueType {
        const Coord base = Coord::floor(ijk);
        const Vec3d w = ijk - base.asVec3d();
        typename Accessor::ValueType sum = openvdb::zeroVal<typename Accessor::ValueType>();
        double weight = 0.0;
        for (int c = 0; c < 8; ++c) {
            const Coord at = base.offsetBy(c & 1, (c >> 1) & 1, (c >> 2) & 1);
            if (!density.isValueOn(at)) continue;
            const double wc = ((c & 1) ? w[0] : 1 - w[0]) * ((c & 2) ? w[1] : 1 - w[1]) *
                              ((c & 4) ? w[2] : 1 - w[2]);
            sum = sum + acc.getValue(at) * static_cast<float>(wc);
            weight += wc;
        }
        return weight > 0 ? sum * static_cast<float>(1.0 / weight) : sum;
    }
};

/// The scene's look: sky, terrain material, light.
struct Look {
    Vec3d light = Vec3d(-0.35, 0.85, 0.4).unitSafe();
    Rgb ground = {0.62f, 0.60f, 0.56f};
    Rgb groundSection = {0.55f, 0.53f, 0.50f};
    Rgb outline = {0.25f, 0.23f, 0.21f};

    Rgb sky(double py, int height) const {
        const float s = static_cast<float>(py / std::max(1, height));
        return {0.78f + 0.18f * s, 0.85f + 0.12f * s, 0.93f + 0.05f * s};
    }
    Rgb lit(const Rgb& base, const Vec3d& normal, float ambient = 0.45f) const {
        const float diffuse = static_cast<float>(std::max(0.0, normal.dot(light)));
        const float s = ambient + (1.f - ambient) * diffuse;
        return {base[0] * s, base[1] * s, base[2] * s};
    }
};

/// What one frame render needs, shared read-only by all rows.
struct FrameScene {
    const VolumeFrameGrids* grids = nullptr;
    const openvdb::BoolTree* occupied = nullptr; // density leaves, dilated by a voxel
    const FloatGrid* terrain = nullptr;
    int dimension = 3;
    double dx = 0.05;
    /// World position of voxel (0, 0, 0): 0, or the local frame's origin of a run on a far-off
    /// DEM (the caches' transforms carry it; firn/gis.h).
    Vec3d indexOrigin{0.0, 0.0, 0.0};
    openvdb::BBoxd volumeBox; // world bounds of the density, one voxel larger
    ColorBy colorBy = ColorBy::Speed;
    std::array<double, 2> range{0.0, 1.0};
    double extinction = 1.0;  // per (kg/m^3) per metre
    double gridSpacing = 1.0; // m, lines on the ground (3D)
    Camera camera;
    Look look;
};

Rgb mix(const Rgb& a, const Rgb& b, float t) {
    return {a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])};
}

/// Front-to-back compositing of a ray.
struct Accumulator {
    Rgb colour = {0.f, 0.f, 0.f};
    float transmittance = 1.f;
    void add(const Rgb& c, float alpha) {
        for (int k = 0; k < 3; ++k) colour[k] += transmittance * alpha * c[k];
        transmittance *= 1.f - alpha;
    }
    bool opaque() const { return transmittance < 0.004f; }
    Rgb over(const Rgb& behind) const {
        return {colour[0] + transmittance * behind[0], colour[1] + transmittance * behind[1],
                colour[2] + transmittance * behind[2]};
    }
};

class PixelShader {
public:
    explicit PixelShader(const FrameScene& s)
        : mScene(s)
        , mSampler(*s.grids, s.colorBy)
        , mOccupied(*s.occupied) {
        if (s.terrain) {
            mTerrainAcc.emplace(s.terrain->getConstAccessor());
            if (s.dimension == 3) mIntersector.emplace(*s.terrain);
        }
    }

    Rgb shade(double px, double py) {
        firn::Vec3d o, d;
        mScene.camera.ray(px, py, o, d);
        const RayT ray(Vec3d(o[0], o[1], o[2]), Vec3d(d[0], d[1], d[2]));
        return mScene.dimension == 2 ? shadeSheet(ray, py) : shadeVolume(ray, py);
    }

private:
    const FrameScene& mScene;
    ColourSampler mSampler;
    openvdb::tree::ValueAccessor<const openvdb::BoolTree> mOccupied;
    std::optional<FloatGrid::ConstAccessor> mTerrainAcc;
    std::optional<openvdb::tools::LevelSetRayIntersector<FloatGrid>> mIntersector;

    Vec3d toIndex(const Vec3d& world) const { return (world - mScene.indexOrigin) / mScene.dx; }

    Rgb sampleColour(const Vec3d& ijk) {
        const auto& r = mScene.range;
        const float t = static_cast<float>((mSampler.value(ijk) - r[0]) / (r[1] - r[0]));
        return colorMap(mScene.colorBy, t);
    }

    /// Outward normal of the snow from the density gradient (index space), 2D or 3D.
    Vec3d densityNormal(const Vec3d& ijk) {
        Vec3d g(0.0);
        for (int a = 0; a < mScene.dimension; ++a) {
            Vec3d e(0.0);
            e[a] = 1.0;
            g[a] = mSampler.rho(ijk - e) - mSampler.rho(ijk + e);
        }
        return g.unitSafe();
    }

    Rgb litSnow(const Vec3d& ijk, float rho) {
        const Vec3d n = densityNormal(ijk);
        // Inside the snow the gradient is noise: blend towards an unlit look as it vanishes.
        const float edge = n.lengthSqr() > 0 ? 1.f : 0.f;
        const Rgb c = sampleColour(ijk);
        const Rgb shaded = mScene.look.lit(c, n, 0.55f);
        return rho > 0 ? mix(c, shaded, 0.8f * edge) : c;
    }

    /// 2D: the run is a sheet in the plane z = 0; the ray meets it once. Snow is composited over
    /// the ground (inside the terrain level set) or the sky.
    Rgb shadeSheet(const RayT& ray, double py) {
        const double dz = ray.dir()[2];
        if (std::abs(dz) < 1e-12) return mScene.look.sky(py, mScene.camera.height);
        const double t = -ray.eye()[2] / dz;
        if (t < 0) return mScene.look.sky(py, mScene.camera.height);
        Vec3d p = ray(t);
        p[2] = 0.0;
        Vec3d ijk = toIndex(p);
        ijk[2] = 0.0;
        Accumulator acc;
        const float rho = mSampler.rho(ijk);
        if (rho > 0.f) {
            // As if the sheet were 4 voxels deep: dense snow is opaque, thin spray is not.
            const float alpha =
                1.f - std::exp(-static_cast<float>(mScene.extinction * rho * 4.0 * mScene.dx));
            acc.add(litSnow(ijk, rho), alpha);
        }
        return acc.over(groundOrSky(p, py));
    }

    Rgb groundOrSky(const Vec3d& p, double py) {
        if (!mTerrainAcc) return mScene.look.sky(py, mScene.camera.height);
        const Vec3d ijk = mScene.terrain->worldToIndex(p);
        const float phi = Sampler::sample(*mTerrainAcc, ijk);
        if (phi > 0.f) return mScene.look.sky(py, mScene.camera.height);
        // A flat cut through the ground, outlined at its surface: the profile reads at a glance.
        const double pixel = mScene.camera.orthoHeight / mScene.camera.height;
        return -phi < 1.5 * pixel ? mScene.look.outline : mScene.look.groundSection;
    }

    /// 3D: terrain hit by the level-set intersector, density integrated in front of it, empty
    /// 8^3 blocks skipped.
    Rgb shadeVolume(const RayT& ray, double py) {
        double tGround = std::numeric_limits<double>::infinity();
        Rgb behind = mScene.look.sky(py, mScene.camera.height);
        if (mIntersector) {
            Vec3d hit, normal;
            double t;
            if (mIntersector->intersectsWS(ray, hit, normal, t)) {
                tGround = t;
                behind = mScene.look.lit(groundWithGrid(hit), normal.unitSafe());
            }
        }
        Accumulator acc;
        RayT clipped(ray);
        if (clipped.clip(mScene.volumeBox)) march(clipped, std::min(clipped.t1(), tGround), acc);
        return acc.over(behind);
    }

    /// Ground colour with faint lines every `gridSpacing` metres in x and z: scale and motion
    /// read against them.
    Rgb groundWithGrid(const Vec3d& p) const {
        const double s = mScene.gridSpacing, width = 0.01;
        const double fx = p[0] / s - std::floor(p[0] / s), fz = p[2] / s - std::floor(p[2] / s);
        const bool line = fx < width || fx > 1 - width || fz < width || fz > 1 - width;
        const Rgb& g = mScene.look.ground;
        return line ? Rgb{0.85f * g[0], 0.85f * g[1], 0.85f * g[2]} : g;
    }

    void march(const RayT& ray, double tEnd, Accumulator& acc) {
        const double step = 0.5 * mScene.dx;
        double t = ray.t0();
        while (t < tEnd && !acc.opaque()) {
            const Vec3d ijk = toIndex(ray(t));
            const Coord voxel = Coord::floor(ijk);
            if (!mOccupied.probeConstLeaf(voxel) && !mOccupied.isValueOn(voxel)) {
                t = std::max(t + 1e-6 * mScene.dx, blockExit(ray, voxel)); // empty block
                continue;
            }
            const double h = std::min(step, tEnd - t);
            const Vec3d mid = toIndex(ray(t + 0.5 * h));
            const float rho = mSampler.rho(mid);
            if (rho > 0.f) {
                const float alpha =
                    1.f - std::exp(-static_cast<float>(mScene.extinction * rho * h));
                if (alpha > 1e-3f) acc.add(litSnow(mid, rho), alpha);
            }
            t += h;
        }
    }

    /// Ray parameter where the ray leaves the 8^3 block of `voxel`.
    double blockExit(const RayT& ray, const Coord& voxel) const {
        const Coord origin = voxel & ~7;
        double exit = std::numeric_limits<double>::infinity();
        for (int a = 0; a < 3; ++a) {
            const double d = ray.dir()[a];
            if (std::abs(d) < 1e-12) continue;
            const double face =
                (d > 0 ? origin[a] + 8 : origin[a]) * mScene.dx + mScene.indexOrigin[a];
            exit = std::min(exit, (face - ray.eye()[a]) / d);
        }
        return exit;
    }
};

Image renderFrame(const FrameScene& scene) {
    const Camera& cam = scene.camera;
    Image image(cam.width, cam.height);
    tbb::parallel_for(tbb::blocked_range<int>(0, cam.height, 4), [&](const auto& rows) {
        PixelShader shader(scene);
        for (int y = rows.begin(); y != rows.end(); ++y) {
            for (int x = 0; x < cam.width; ++x) image.set(x, y, shader.shade(x + 0.5, y + 0.5));
        }
    });
    return image;
}

std::string timeLabel(double time) {
    char text[64];
    std::snprintf(text, sizeof text, "t = %.2f s", time);
    return text;
}

void annotate(Image& image, const VolumeFrameGrids& f, ColorBy colorBy,
              const std::array<double, 2>& range) {
    const int scale = image.width >= 640 ? 2 : 1;
    const Rgb ink = {0.08f, 0.08f, 0.1f};
    drawText(image, 10 * scale, 10 * scale, timeLabel(f.time), ink, scale);
    const int barW = std::max(40, image.width / 4), barH = 7 * scale;
    drawColorBar(image, image.width - barW - 16 * scale, image.height - barH - 18 * scale, barW,
                 barH, colorBy, range);
}

/// Union of the density bounds over the frames (world), and the colour quantity's largest value.
VolumeCacheExtent scanFrames(const std::vector<std::pair<int, std::string>>& frames,
                             ColorBy colorBy) {
    VolumeCacheExtent s;
    openvdb::BBoxd box;
    for (const auto& [number, path] : frames) {
        const VolumeFrameGrids f = readFrame(number, path, colorBy);
        s.dx = f.density->voxelSize()[0];
        const openvdb::CoordBBox ib = f.density->evalActiveVoxelBoundingBox();
        if (!ib.empty()) {
            box.expand(f.density->indexToWorld(ib.min().asVec3d()));
            box.expand(f.density->indexToWorld(ib.max().asVec3d()));
        }
        float hi = 0.f;
        for (auto it = f.density->cbeginValueOn(); it; ++it) hi = std::max(hi, *it);
        s.maxDensity = std::max<double>(s.maxDensity, hi);
        if (f.velocity) {
            for (auto it = f.velocity->cbeginValueOn(); it; ++it)
                s.maxValue = std::max<double>(s.maxValue, it->length());
        }
        if (f.eta) {
            for (auto it = f.eta->cbeginValueOn(); it; ++it)
                s.maxValue = std::max<double>(s.maxValue, *it);
        }
    }
    if (colorBy == ColorBy::Density) s.maxValue = s.maxDensity;
    // isSorted, not empty(): a 2D run is a flat box, which BBox calls empty.
    if (box.isSorted()) {
        s.box.min = {box.min()[0], box.min()[1], box.min()[2]};
        s.box.max = {box.max()[0], box.max()[1], box.max()[2]};
    }
    return s;
}

FloatGrid::Ptr readTerrain(const std::string& outDir, bool quiet) {
    const std::string path = outDir + "/terrain.vdb";
    std::error_code error;
    if (!fs::exists(path, error)) {
        if (!quiet)
            std::fprintf(stderr, "firn render: no %s: rendering without terrain\n", path.c_str());
        return nullptr;
    }
    try {
        openvdb::io::File file(path);
        file.open();
        auto grid = openvdb::gridPtrCast<FloatGrid>(file.readGrid("surface"));
        file.close();
        if (!grid || grid->getGridClass() != openvdb::GRID_LEVEL_SET) {
            throw IoError(path + ": grid 'surface' is not a float level set");
        }
        return grid;
    } catch (const openvdb::Exception& e) {
        throw IoError(path + ": cannot read: " + e.what());
    }
}

std::string findProgram(const std::string& name) {
    if (name.find('/') != std::string::npos) return access(name.c_str(), X_OK) == 0 ? name : "";
    const char* path = std::getenv("PATH");
    std::stringstream dirs(path ? path : "");
    std::string dir;
    while (std::getline(dirs, dir, ':')) {
        const std::string candidate = (dir.empty() ? "." : dir) + "/" + name;
        if (access(candidate.c_str(), X_OK) == 0) return candidate;
    }
    return "";
}

/// Runs a program without a shell (no quoting of paths); returns its exit status.
int runProgram(const std::vector<std::string>& argv) {
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    std::fflush(nullptr);
    const pid_t pid = fork();
    if (pid < 0) return -1;
    if (pid == 0) {
        execv(args[0], args.data());
        _exit(127);
    }
    int status = 0;
    if (waitpid(pid, &status, 0) < 0) return -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::vector<std::string> writeVideos(const std::string& ffmpeg, const std::string& dir, double fps,
                                     bool quiet) {
    const std::string input = dir + "/frame.*.png";
    const std::string rate = std::to_string(fps);
    std::vector<std::string> written;
    const std::vector<std::pair<std::string, std::vector<std::string>>> videos = {
        {dir + "/animation.mp4",
         {"-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-pix_fmt", "yuv420p", "-c:v", "libx264"}},
        {dir + "/animation.gif",
         {"-vf", "scale=480:-1:flags=lanczos,split[a][b];[a]palettegen[p];[b][p]paletteuse"}}};
    for (const auto& [out, codec] : videos) {
        std::vector<std::string> argv = {ffmpeg,       "-y", "-loglevel",     "error",
                                         "-framerate", rate, "-pattern_type", "glob",
                                         "-i",         input};
        argv.insert(argv.end(), codec.begin(), codec.end());
        argv.push_back(out);
        const int status = runProgram(argv);
        if (status == 0) {
            written.push_back(out);
        } else if (!quiet) {
            std::fprintf(stderr, "firn render: ffmpeg failed (exit %d) writing %s\n", status,
                         out.c_str());
        }
    }
    return written;
}

std::string jsonVec(const firn::Vec3d& v) {
    char text[128];
    std::snprintf(text, sizeof text, "[%.6g, %.6g, %.6g]", v[0], v[1], v[2]);
    return text;
}

void writeRenderJson(const std::string& path, const RenderResult& r, const RenderOptions& o,
                     int threads) {
    std::ostringstream j;
    const Camera& c = r.camera;
    j << "{\n  \"frames\": " << r.frames << ",\n  \"width\": " << c.width
      << ",\n  \"height\": " << c.height << ",\n  \"color_by\": \"" << toString(o.view.colorBy)
      << "\",\n  \"color_range\": [" << r.colorRange[0] << ", " << r.colorRange[1]
      << "],\n  \"camera_position\": " << jsonVec(c.position)
      << ",\n  \"look_at\": " << jsonVec(c.lookAt) << ",\n  \"fov_deg\": " << c.fovDeg
      << ",\n  \"orthographic\": " << (c.orthographic ? "true" : "false")
      << ",\n  \"ortho_height\": " << c.orthoHeight
      << ",\n  \"seconds_per_frame\": " << r.secondsPerFrame << ",\n  \"threads\": " << threads
      << ",\n  \"videos\": [";
    for (std::size_t i = 0; i < r.videos.size(); ++i)
        j << (i ? ", " : "") << "\"" << fs::path(r.videos[i]).filename().string() << "\"";
    j << "]\n}\n";
    FILE* file = std::fopen(path.c_str(), "w");
    if (!file || std::fputs(j.str().c_str(), file) < 0 || std::fclose(file) != 0)
        throw IoError(path + ": cannot write");
}

std::vector<std::pair<int, std::string>> selectFrames(const std::map<int, std::string>& all,
                                                      const RenderOptions& o) {
    const int last = o.lastFrame < 0 ? all.rbegin()->first : o.lastFrame;
    std::vector<std::pair<int, std::string>> chosen;
    for (const auto& [number, path] : all) {
        if (number >= o.firstFrame && number <= last && (number - o.firstFrame) % o.frameStep == 0)
            chosen.emplace_back(number, path);
    }
    if (chosen.empty()) {
        throw IoError("no volume frames between " + std::to_string(o.firstFrame) + " and " +
                      std::to_string(last) + " (the cache has frames " +
                      std::to_string(all.begin()->first) + " to " +
                      std::to_string(all.rbegin()->first) + ")");
    }
    return chosen;
}

void removeOldFrames(const std::string& dir) {
    static const std::regex name(R"(frame\.\d{4,}\.png)");
    for (const auto& entry : fs::directory_iterator(dir)) {
        if (std::regex_match(entry.path().filename().string(), name)) fs::remove(entry.path());
    }
}

} // namespace

VolumeCacheExtent scanVolumeCache(const std::string& outDir, const RenderOptions& options) {
    openvdb::initialize();
    return scanFrames(selectFrames(listVolumeFrames(outDir), options), options.view.colorBy);
}

RenderResult renderOutput(const std::string& outDir, const RenderOptions& options) {
    openvdb::initialize();
    const RenderDesc& view = options.view;
    const auto frames = selectFrames(listVolumeFrames(outDir), options);
    const int threads = options.threads > 0 ? options.threads : tbb::info::default_concurrency();
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);

    const VolumeCacheExtent stats = scanFrames(frames, view.colorBy);
    RenderResult result;
    result.directory = options.directory.empty() ? outDir + "/render" : options.directory;
    std::error_code error;
    fs::create_directories(result.directory, error);
    if (error) throw IoError(result.directory + ": cannot create: " + error.message());
    removeOldFrames(result.directory);

    FrameScene scene;
    scene.dimension = options.dimension;
    scene.dx = stats.dx;
    scene.colorBy = view.colorBy;
    const bool userRange = std::isfinite(view.colorRange[0]) && std::isfinite(view.colorRange[1]);
    if (userRange) {
        scene.range = view.colorRange;
    } else if (view.colorBy == ColorBy::Failed) {
        scene.range = {0.0, 1.0};
    } else {
        scene.range = {0.0, stats.maxValue > 0 ? stats.maxValue : 1.0};
    }
    // Half a voxel of path through a twentieth of the densest snow is ~40 % opaque: dense snow
    // has a crisp surface, powder stays see-through.
    const double opaqueDensity =
        options.opaqueDensity > 0 ? options.opaqueDensity : stats.maxDensity;
    scene.extinction = 1.0 / (0.05 * std::max(opaqueDensity, 1e-6) * stats.dx);
    const FloatGrid::Ptr terrain = readTerrain(outDir, options.quiet);
    scene.terrain = terrain.get();

    if (options.camera) {
        scene.camera = *options.camera;
    } else if (view.autoCamera) {
        scene.camera = frameBox(stats.box, options.dimension, view.width, view.height, view.fovDeg);
    } else {
        scene.camera.position = view.cameraPosition;
        scene.camera.lookAt = view.lookAt;
        scene.camera.fovDeg = view.fovDeg;
        scene.camera.width = view.width;
        scene.camera.height = view.height;
    }

    const int sheetCount = std::min<int>(view.contactFrames, static_cast<int>(frames.size()));
    std::vector<int> sheetIndex; // evenly spaced over the rendered frames, first and last included
    for (int i = 0; i < sheetCount; ++i) {
        sheetIndex.push_back(sheetCount == 1
                                 ? static_cast<int>(frames.size()) - 1
                                 : static_cast<int>(std::lround(double(i) * (frames.size() - 1) /
                                                                (sheetCount - 1))));
    }
    std::vector<Image> sheetImages;
    double renderSeconds = 0.0, frameRate = 24.0;
    const bool stderrIsTerminal = isatty(fileno(stderr));
    for (std::size_t i = 0; i < frames.size(); ++i) {
        const VolumeFrameGrids grids = readFrame(frames[i].first, frames[i].second, view.colorBy);
        frameRate = grids.frameRate;
        openvdb::BoolTree occupied(grids.density->tree(), false, openvdb::TopologyCopy());
        // EXPAND_TILES keeps every block a leaf (PRESERVE_TILES would fold full ones into tiles).
        openvdb::tools::dilateActiveValues(occupied, 1, openvdb::tools::NN_FACE_EDGE_VERTEX,
                                           openvdb::tools::EXPAND_TILES);
        scene.grids = &grids;
        scene.occupied = &occupied;
        scene.indexOrigin = grids.density->indexToWorld(openvdb::Vec3d(0.0, 0.0, 0.0));
        const openvdb::CoordBBox ib = grids.density->evalActiveVoxelBoundingBox();
        scene.volumeBox = openvdb::BBoxd(grids.density->indexToWorld(ib.min().asVec3d() - 1.0),
                                         grids.density->indexToWorld(ib.max().asVec3d() + 1.0));
        const auto start = std::chrono::steady_clock::now();
        Image image = renderFrame(scene);
        renderSeconds +=
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        annotate(image, grids, view.colorBy, scene.range);
        char name[32];
        std::snprintf(name, sizeof name, "/frame.%04d.png", frames[i].first);
        writePng(result.directory + name, image);
        if (std::find(sheetIndex.begin(), sheetIndex.end(), static_cast<int>(i)) !=
            sheetIndex.end())
            sheetImages.push_back(std::move(image));
        if (!options.quiet) {
            // One updating line on a terminal; in a log (no terminal) one line per frame, so
            // that the lines do not run together.
            std::fprintf(stderr, "%sfirn render: frame %zu/%zu (%.2f s/frame)%s",
                         stderrIsTerminal ? "\r\033[K" : "", i + 1, frames.size(),
                         renderSeconds / (i + 1), stderrIsTerminal ? "" : "\n");
            std::fflush(stderr);
        }
    }
    if (!options.quiet && stderrIsTerminal) std::fputc('\n', stderr);
    const int columns = sheetImages.size() <= 4 ? 2 : sheetImages.size() <= 9 ? 3 : 4;
    const double scale = std::min(0.5, 1920.0 / (columns * view.width));
    writePng(result.directory + "/contact.png", contactSheet(sheetImages, columns, scale));

    result.frames = static_cast<int>(frames.size());
    result.secondsPerFrame = renderSeconds / frames.size();
    result.colorRange = scene.range;
    result.camera = scene.camera;
    if (options.video) {
        const std::string ffmpeg = findProgram(options.ffmpeg);
        if (ffmpeg.empty()) {
            if (!options.quiet)
                std::fprintf(stderr, "firn render: ffmpeg not found: no MP4/GIF written\n");
        } else if (frames.size() > 1) {
            result.videos =
                writeVideos(ffmpeg, result.directory, frameRate / options.frameStep, options.quiet);
        }
    }
    writeRenderJson(result.directory + "/render.json", result, options, threads);
    return result;
}

} // namespace firn
