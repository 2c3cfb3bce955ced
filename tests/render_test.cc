// The review renderer: cameras, colour maps, images, and `renderOutput` end to end on a short
// run of the default scene, asserting on what the pictures show.
#include <firn/render.h>
#include <firn/run.h>

#include "cli/render_command.h"
#include "test_util.h"

#include <firn_test_paths.h>

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

using namespace firn;
using firn::test::TempDir;

namespace {

/// Snow pixels are coloured by a saturated map; sky, ground and ink are near grey or pale blue.
bool isSnow(const std::uint8_t* p) {
    const int hi = std::max({p[0], p[1], p[2]}), lo = std::min({p[0], p[1], p[2]});
    const bool paleSky = p[2] > 200 && p[0] > 180;
    return hi - lo > 45 && !paleSky;
}

struct SnowExtent {
    int count = 0, minX = 1 << 30, maxX = -1, minY = 1 << 30, maxY = -1;
};

/// Where the snow is, leaving out the colour bar's corner.
SnowExtent snowExtent(const Image& image) {
    SnowExtent e;
    for (int y = 0; y < image.height; ++y) {
        for (int x = 0; x < image.width; ++x) {
            const bool colourBar = x > image.width * 2 / 3 && y > image.height * 4 / 5;
            if (colourBar || !isSnow(image.pixel(x, y))) continue;
            ++e.count;
            e.minX = std::min(e.minX, x), e.maxX = std::max(e.maxX, x);
            e.minY = std::min(e.minY, y), e.maxY = std::max(e.maxY, y);
        }
    }
    return e;
}

std::string slurp(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Runs scenes/granular-slide.toml (2D granular release on the 25 m slope) for `endTime` seconds
/// into `dir`.
void runGranularSlide(const TempDir& dir, double endTime) {
    const std::string path = FIRN_SOURCE_DIR "/scenes/granular-slide.toml";
    const SceneDesc scene =
        parseScene(slurp(path), path, {"simulation.end_time=" + std::to_string(endTime)});
    RunOptions run;
    run.outDir = dir.path();
    run.quiet = true;
    REQUIRE(runScene(scene, run).status == "ok");
}

} // namespace

TEST_CASE("The automatic 3D camera keeps every corner of the box inside the image", "[render]") {
    const Box3 box{{-2.0, 0.0, -1.0}, {6.0, 1.5, 1.0}};
    const Camera c = frameBox(box, 3, 960, 540, 40.0);
    double minX = 1e9, maxX = -1e9, minY = 1e9, maxY = -1e9;
    for (int corner = 0; corner < 8; ++corner) {
        const Vec3d p = {(corner & 1) ? box.max[0] : box.min[0],
                         (corner & 2) ? box.max[1] : box.min[1],
                         (corner & 4) ? box.max[2] : box.min[2]};
        double px, py;
        REQUIRE(c.project(p, px, py));
        minX = std::min(minX, px), maxX = std::max(maxX, px);
        minY = std::min(minY, py), maxY = std::max(maxY, py);
    }
    // Inside with the 6 % margin, and tight: the box fills the image in one direction, within
    // the bisection's resolution (far below a pixel).
    const double margin = 0.06 * 540;
    CHECK(minX >= margin - 1e-6);
    CHECK(minY >= margin - 1e-6);
    CHECK(maxX <= 960 - margin + 1e-6);
    CHECK(maxY <= 540 - margin + 1e-6);
    CHECK(std::min({minX - margin, minY - margin, 960 - margin - maxX, 540 - margin - maxY}) < 1.0);
}

TEST_CASE("The 2D camera is an orthographic side view that fits the x-y box", "[render]") {
    const Box3 box{{3.0, 0.0, 0.0}, {30.0, 12.0, 0.0}};
    const Camera c = frameBox(box, 2, 960, 540, 40.0);
    CHECK(c.orthographic);
    double px, py;
    REQUIRE(c.project({3.0, 0.0, 0.0}, px, py));
    CHECK(px > 0.0);
    CHECK(py < 540.0);
    REQUIRE(c.project({30.0, 12.0, 0.0}, px, py));
    CHECK(px < 960.0);
    CHECK(py > 0.0);
    // Rays of an orthographic camera are parallel: -z for the side view.
    Vec3d o, d;
    c.ray(10.5, 20.5, o, d);
    CHECK(d[2] == Approx(-1.0));
}

TEST_CASE("A pixel's ray passes through the point that projects to that pixel", "[render]") {
    Camera c;
    c.position = {3.0, 4.0, 10.0};
    c.lookAt = {0.0, 1.0, 0.0};
    c.width = 320, c.height = 200, c.fovDeg = 50.0;
    for (const auto& [px, py] : {std::pair{10.5, 20.5}, {160.0, 100.0}, {300.25, 190.75}}) {
        Vec3d o, d;
        c.ray(px, py, o, d);
        const Vec3d p = {o[0] + 7.0 * d[0], o[1] + 7.0 * d[1], o[2] + 7.0 * d[2]};
        double qx, qy;
        REQUIRE(c.project(p, qx, qy));
        CHECK(qx == Approx(px).margin(1e-9));
        CHECK(qy == Approx(py).margin(1e-9));
    }
}

TEST_CASE("Colour maps run from their dark to their light end", "[render]") {
    auto luminance = [](const Rgb& c) { return 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2]; };
    for (ColorBy q : {ColorBy::Speed, ColorBy::Density, ColorBy::Eta}) {
        float previous = -1.f;
        for (int i = 0; i <= 20; ++i) {
            const float l = luminance(colorMap(q, i / 20.f));
            CHECK(l > previous); // perceptually ordered: brighter is more
            previous = l;
        }
    }
    // Failed: blue for elastic, red for failed; out-of-range and NaN inputs clamp.
    CHECK(colorMap(ColorBy::Failed, 0.f)[2] > colorMap(ColorBy::Failed, 0.f)[0]);
    CHECK(colorMap(ColorBy::Failed, 1.f)[0] > colorMap(ColorBy::Failed, 1.f)[2]);
    CHECK(colorMap(ColorBy::Speed, 2.f) == colorMap(ColorBy::Speed, 1.f));
    CHECK(colorMap(ColorBy::Speed, std::nanf("")) == colorMap(ColorBy::Speed, 0.f));
}

TEST_CASE("PNG files round-trip, and a missing one is a clear error", "[render]") {
    TempDir dir("firn-png");
    Image image(37, 11, {10, 20, 30});
    image.set(5, 7, {1.f, 0.5f, 0.f});
    drawText(image, 12, 2, "t=1.5 s", {1.f, 1.f, 1.f}, 1);
    const std::string path = dir.path() + "/a.png";
    writePng(path, image);
    const Image back = readPng(path);
    CHECK(back.width == 37);
    CHECK(back.height == 11);
    CHECK(back.rgb == image.rgb);
    CHECK_THROWS_WITH(readPng(dir.path() + "/none.png"), Catch::Contains("none.png"));
    CHECK_THROWS_WITH(writePng(dir.path() + "/no/such/folder.png", image),
                      Catch::Contains("no/such/folder.png"));
}

TEST_CASE("Text draws known glyphs and skips unknown ones", "[render]") {
    auto inked = [](const std::string& text) {
        Image image(80, 10, {0, 0, 0});
        drawText(image, 0, 0, text, {1.f, 1.f, 1.f}, 1);
        return static_cast<int>(std::count(image.rgb.begin(), image.rgb.end(), 255)) / 3;
    };
    CHECK(inked("8") > inked("1"));
    CHECK(inked("speed") > 0);
    CHECK(inked("SPEED") == inked("speed")); // upper case draws as lower case
    CHECK(inked("#&") == 0);
}

TEST_CASE("A contact sheet tiles and box-filters its frames", "[render]") {
    const Image black(40, 20, {0, 0, 0}), white(40, 20, {255, 255, 255});
    const Image sheet = contactSheet({black, white, black}, 2, 0.5);
    // 2 columns x 2 rows of 20 x 10 tiles with 4-pixel gaps.
    CHECK(sheet.width == 2 * 20 + 3 * 4);
    CHECK(sheet.height == 2 * 10 + 3 * 4);
    CHECK(sheet.pixel(4 + 5, 4 + 5)[0] == 0);     // first tile: black
    CHECK(sheet.pixel(28 + 5, 4 + 5)[0] == 255);  // second: white
    CHECK(sheet.pixel(4 + 5, 18 + 5)[0] == 0);    // third, next row
    CHECK(sheet.pixel(28 + 5, 18 + 5)[0] == 255); // no fourth frame: background
}

TEST_CASE("firn render draws the avalanche, framed, coloured over its range", "[render][e2e]") {
    TempDir dir("firn-render");
    runGranularSlide(dir, 1.5);

    RenderOptions options;
    options.dimension = 2;
    options.view.width = 480, options.view.height = 270;
    options.frameStep = 6;
    options.video = false;
    options.quiet = true;
    options.threads = 1;
    const RenderResult r = renderOutput(dir.path(), options);
    CHECK(r.frames == 4); // frames 0, 6, 12, 18 of 0..18
    // The colour range spans the speeds of the run: 0 to the fastest voxel, which the 1.5 s of
    // gravity-driven flow on this slope brings to a few m/s.
    CHECK(r.colorRange[0] == 0.0);
    CHECK(r.colorRange[1] > 1.0);
    CHECK(r.colorRange[1] < 15.0);

    const Image first = readPng(dir.path() + "/render/frame.0000.png");
    const Image last = readPng(dir.path() + "/render/frame.0018.png");
    REQUIRE(first.width == 480);
    REQUIRE(first.height == 270);
    for (const Image* image : {&first, &last}) {
        const SnowExtent e = snowExtent(*image);
        // The release is 9 m long and 0.5 m deep in a ~25 m wide view: hundreds of pixels of
        // snow, none cut by the image border (the camera frames every frame's snow).
        CHECK(e.count > 300);
        CHECK(e.minX > 2);
        CHECK(e.minY > 2);
        CHECK(e.maxX < image->width - 3);
        CHECK(e.maxY < image->height - 3);
    }
    // At rest the slab is the low end of the map (dark violet); moving snow is lighter.
    auto meanGreen = [](const Image& image) {
        double sum = 0;
        int n = 0;
        for (int y = 0; y < image.height; ++y)
            for (int x = 0; x < image.width * 2 / 3; ++x)
                if (isSnow(image.pixel(x, y))) sum += image.pixel(x, y)[1], ++n;
        return n ? sum / n : 0.0;
    };
    CHECK(meanGreen(last) > meanGreen(first) + 30.0);

    // The colour bar spans the map: dark violet at its left end, yellow at its right.
    const int barY = last.height - 7 - 18 + 3, barW = std::max(40, last.width / 4);
    const int barX0 = last.width - barW - 16;
    const std::uint8_t* left = last.pixel(barX0 + 1, barY);
    const std::uint8_t* right = last.pixel(barX0 + barW - 2, barY);
    CHECK(int(left[0]) + left[1] + left[2] < 250);
    CHECK(right[0] > 200);
    CHECK(right[1] > 180);
    CHECK(right[2] < 100);

    // The same pictures whatever the thread count.
    options.threads = 2;
    renderOutput(dir.path(), options);
    CHECK(readPng(dir.path() + "/render/frame.0018.png").rgb == last.rgb);
    CHECK(std::filesystem::exists(dir.path() + "/render/contact.png"));
    CHECK(slurp(dir.path() + "/render/render.json").find("\"color_by\": \"speed\"") !=
          std::string::npos);
}

TEST_CASE("firn render names what is missing", "[render]") {
    TempDir dir("firn-render-missing");
    RenderOptions options;
    options.quiet = true;
    CHECK_THROWS_WITH(renderOutput(dir.path(), options), Catch::Contains("firn run"));
    std::filesystem::create_directories(dir.path() + "/frames");
    CHECK_THROWS_WITH(renderOutput(dir.path(), options), Catch::Contains("volume.NNNN.vdb"));
}

TEST_CASE("Videos come from ffmpeg when it is there, and are skipped cleanly when not",
          "[render]") {
    TempDir dir("firn-render-video");
    runGranularSlide(dir, 0.25);
    RenderOptions options;
    options.dimension = 2;
    options.view.width = 160, options.view.height = 90;
    options.quiet = true;
    options.ffmpeg = "firn-no-such-ffmpeg";
    CHECK(renderOutput(dir.path(), options).videos.empty());
    CHECK_FALSE(std::filesystem::exists(dir.path() + "/render/animation.mp4"));
    if (!std::filesystem::exists("/usr/bin/ffmpeg")) return; // Debian's ffmpeg: optional
    options.ffmpeg = "ffmpeg";
    const RenderResult r = renderOutput(dir.path(), options);
    REQUIRE(r.videos.size() == 2);
    for (const std::string& video : r.videos) CHECK(std::filesystem::file_size(video) > 1000);
}

TEST_CASE("firn render options become [render] overrides, and bad ones are usage errors",
          "[render]") {
    using firn::cli::parseRenderCommand;
    const auto c = parseRenderCommand({"out/x", "--size", "640x360", "--color-by", "eta",
                                       "--camera", "1,2,3", "--look-at", "0,0,0", "--frames",
                                       "4:20:2", "--no-video", "--threads", "2"});
    CHECK(c.outDir == "out/x");
    CHECK(c.options.firstFrame == 4);
    CHECK(c.options.lastFrame == 20);
    CHECK(c.options.frameStep == 2);
    CHECK_FALSE(c.options.video);
    CHECK(c.options.threads == 2);
    const SceneDesc d = parseScene("[simulation]\nname = \"x\"\n", "out/x/scene.toml", c.overrides);
    CHECK(d.render.width == 640);
    CHECK(d.render.height == 360);
    CHECK(d.render.colorBy == ColorBy::Eta);
    CHECK_FALSE(d.render.autoCamera);
    CHECK(d.render.cameraPosition[2] == 3.0);
    CHECK_THROWS_WITH(parseRenderCommand({"out/x", "--size", "640"}),
                      Catch::Contains("WIDTHxHEIGHT"));
    CHECK_THROWS_WITH(parseRenderCommand({"out/x", "--frames", "a:b"}),
                      Catch::Contains("--frames"));
    CHECK_THROWS_WITH(parseRenderCommand({"--quiet"}), Catch::Contains("needs an output folder"));
    CHECK_THROWS_WITH(parseRenderCommand({"out/x", "--bogus"}), Catch::Contains("--bogus"));
    CHECK_THROWS_WITH(parseScene("[simulation]\nname = \"x\"\n", "s.toml",
                                 parseRenderCommand({"out/x", "--color-by", "mass"}).overrides),
                      Catch::Contains("render.color_by"));
}
