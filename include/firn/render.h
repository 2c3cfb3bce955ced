// Built-in review renderer (`firn render`): volume caches to PNG frames, a contact sheet and a
// video. Pure pieces (images, colour maps, cameras) are here for tests; renderOutput ties them to
// an output folder.
#pragma once

#include <firn/scene.h>

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace firn {

using Rgb = std::array<float, 3>; ///< linear 0..1

/// An 8-bit RGB image, row 0 at the top.
struct Image {
    int width = 0;
    int height = 0;
    std::vector<std::uint8_t> rgb; ///< 3 bytes per pixel, row-major

    Image() = default;
    Image(int w, int h, std::array<std::uint8_t, 3> fill = {0, 0, 0});
    std::uint8_t* pixel(int x, int y) { return rgb.data() + 3 * (std::size_t(y) * width + x); }
    const std::uint8_t* pixel(int x, int y) const {
        return rgb.data() + 3 * (std::size_t(y) * width + x);
    }
    void set(int x, int y, const Rgb& colour);
};

/// Writes an 8-bit RGB PNG, through a temporary name and a rename. Throws IoError.
void writePng(const std::string& path, const Image& image);
/// Reads an 8-bit RGB or RGBA PNG (alpha dropped). Throws IoError.
Image readPng(const std::string& path);

/// Colour of t in [0, 1] (clamped) for a quantity: density and speed on a viridis-like ramp, eta
/// on a magma-like ramp, failed fraction from blue (elastic) to red (failed).
Rgb colorMap(ColorBy quantity, float t);

/// Draws `text` with the built-in 5x7 font (digits, lower-case letters, " .-+=/()%") at pixel
/// (x, y) = its top-left corner, `scale` pixels per font pixel; other characters draw as blanks.
void drawText(Image& image, int x, int y, const std::string& text, const Rgb& colour,
              int scale = 2);

/// A horizontal colour bar at (x, y) with its range and the quantity's name and unit.
void drawColorBar(Image& image, int x, int y, int width, int height, ColorBy quantity,
                  const std::array<double, 2>& range);

/// Tiles `frames` (all the same size) into a sheet `columns` wide, each scaled by `scale`.
Image contactSheet(const std::vector<Image>& frames, int columns, double scale);

struct Box3 {
    Vec3d min{0, 0, 0};
    Vec3d max{0, 0, 0};
};

/// A pinhole camera, or an orthographic one (2D side views).
struct Camera {
    Vec3d position{0, 0, 10};
    Vec3d lookAt{0, 0, 0};
    Vec3d up{0, 1, 0};
    double fovDeg = 40.0;      ///< vertical, perspective only
    bool orthographic = false; ///< rays parallel to the view direction
    double orthoHeight = 1.0;  ///< m visible vertically, orthographic only
    int width = 960;
    int height = 540;

    /// Ray through pixel coordinates (px, py) (pixel centres at +0.5; y down): origin and unit
    /// direction.
    void ray(double px, double py, Vec3d& origin, Vec3d& direction) const;
    /// Pixel coordinates of a world point; false when it is behind the camera.
    bool project(const Vec3d& point, double& px, double& py) const;
};

/// The automatic camera: frames `box` with a margin. 2D runs (x-y plane) get an orthographic side
/// view along -z; 3D runs a perspective view from down-slope-left, 30 degrees above the horizon,
/// looking at the box centre.
Camera frameBox(const Box3& box, int dimension, int width, int height, double fovDeg);

struct RenderOptions {
    RenderDesc view;    ///< [render] of the run's scene.toml, command-line overrides
    int dimension = 3;  ///< of the run: 2 renders the x-y sheet, 3 the volume
    int firstFrame = 0; ///< first frame number rendered
    int lastFrame = -1; ///< last frame number rendered, -1 = the last in the cache
    int frameStep = 1;  ///< every n-th frame
    int threads = 0;    ///< 0 = all cores
    bool video = true;  ///< MP4 and GIF with ffmpeg, when it is installed
    bool quiet = false; ///< no progress line on stderr
    std::string ffmpeg = "ffmpeg";
    /// Where the PNGs, contact sheet and render.json go; empty: OUT_DIR/render.
    std::string directory;
    /// A camera that replaces the one of `view` (`firn compare` frames two runs with one).
    std::optional<Camera> camera;
    /// kg/m^3, the density at which snow looks opaque; 0: the densest voxel of the frames.
    /// Two runs drawn with the same value look alike where their snow is alike.
    double opaqueDensity = 0.0;
};

/// What a volume cache spans over the frames that `options` selects.
struct VolumeCacheExtent {
    Box3 box;                ///< world bounds of the density over the frames
    double maxValue = 0.0;   ///< largest value of the colour quantity (speed, eta, density)
    double maxDensity = 0.0; ///< kg/m^3
    double dx = 0.0;         ///< voxel size, m
};

/// Reads OUT_DIR/frames/volume.NNNN.vdb (the frames `options` selects) for the bounds and
/// ranges that the automatic camera and colour range come from. Throws IoError like
/// renderOutput.
VolumeCacheExtent scanVolumeCache(const std::string& outDir, const RenderOptions& options);

struct RenderResult {
    int frames = 0;
    double secondsPerFrame = 0.0; ///< wall time of the ray marching, per frame
    std::array<double, 2> colorRange{0.0, 1.0};
    Camera camera;
    std::string directory;           ///< OUT_DIR/render
    std::vector<std::string> videos; ///< written animation files; empty without ffmpeg
};

/// Renders OUT_DIR/frames/volume.NNNN.vdb to OUT_DIR/render/frame.NNNN.png (or
/// options.directory) with the terrain of
/// OUT_DIR/terrain.vdb (when there), then contact.png, render.json and, with ffmpeg, the videos.
/// Throws IoError (missing or unreadable cache, a grid the colour needs is not in the cache).
RenderResult renderOutput(const std::string& outDir, const RenderOptions& options);

} // namespace firn
