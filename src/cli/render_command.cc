#include "render_command.h"

#include <firn/scene.h>

#include <cstdio>
#include <stdexcept>

namespace firn::cli {

const char* const kRenderHelp = R"(usage: firn render OUT_DIR [options]

Renders the volume cache of a run (OUT_DIR/frames/volume.NNNN.vdb) over its terrain
(OUT_DIR/terrain.vdb) to OUT_DIR/render/frame.NNNN.png, a contact sheet contact.png, render.json
(camera, colour range, timing) and, when ffmpeg is installed, animation.mp4 and animation.gif.
Defaults come from the [render] table of OUT_DIR/scene.toml; these options override it.
2D runs are drawn as a side view of the x-y plane, 3D runs from a camera that frames the snow of
every frame.

options:
  --color-by Q          density | speed | failed | eta (default speed; failed and eta need
                        those grids in output.volumes)
  --color-range LO,HI   colour-map range (default 0 to the largest value over the frames;
                        failed: 0,1)
  --size WxH            image size in pixels (default 960x540)
  --camera X,Y,Z        camera position, m (with --look-at; default: automatic framing)
  --look-at X,Y,Z       point the camera looks at, m
  --fov DEG             vertical field of view of a positioned camera (default 40)
  --frames A:B[:S]      frames A to B, every S-th (default: all); A: or :B leave an end open
  --contact-frames N    frames on the contact sheet (default 12)
  --no-video            do not write animation.mp4 / animation.gif
  --threads N           worker threads (default: all cores); images are identical for any N
  --quiet               no progress line on stderr
  -h, --help            this text
)";

namespace {

std::string next(const std::vector<std::string>& args, std::size_t& i) {
    if (i + 1 >= args.size()) throw std::invalid_argument(args[i] + " needs a value");
    return args[++i];
}

int toInt(const std::string& text, const std::string& option, int minimum) {
    std::size_t used = 0;
    int value = 0;
    try {
        value = std::stoi(text, &used);
    } catch (const std::exception&) {
        used = 0;
    }
    if (used == 0 || used != text.size() || value < minimum) {
        throw std::invalid_argument(option + " must be an integer >= " + std::to_string(minimum) +
                                    ", got '" + text + "'");
    }
    return value;
}

/// "1,2,3" -> "[1,2,3]" (a TOML array for the scene reader, which checks the numbers).
std::string tomlArray(const std::string& text) {
    return "[" + text + "]";
}

void parseFrames(const std::string& text, RenderOptions& o) {
    const std::size_t colon = text.find(':');
    if (colon == std::string::npos) {
        o.firstFrame = o.lastFrame = toInt(text, "--frames", 0);
        return;
    }
    const std::string first = text.substr(0, colon), rest = text.substr(colon + 1);
    const std::size_t colon2 = rest.find(':');
    const std::string last = rest.substr(0, colon2);
    if (!first.empty()) o.firstFrame = toInt(first, "--frames (first)", 0);
    if (!last.empty()) o.lastFrame = toInt(last, "--frames (last)", o.firstFrame);
    if (colon2 != std::string::npos)
        o.frameStep = toInt(rest.substr(colon2 + 1), "--frames (step)", 1);
}

} // namespace

RenderCommand parseRenderCommand(const std::vector<std::string>& args) {
    RenderCommand c;
    for (std::size_t i = 0; i < args.size(); ++i) {
        const std::string& a = args[i];
        if (a == "-h" || a == "--help") {
            c.help = true;
        } else if (a == "--color-by") {
            c.overrides.push_back("render.color_by=\"" + next(args, i) + "\"");
        } else if (a == "--color-range") {
            c.overrides.push_back("render.color_range=" + tomlArray(next(args, i)));
        } else if (a == "--size") {
            const std::string size = next(args, i);
            const std::size_t x = size.find('x');
            if (x == std::string::npos) {
                throw std::invalid_argument("--size takes WIDTHxHEIGHT, e.g. 1280x720; got '" +
                                            size + "'");
            }
            c.overrides.push_back("render.width=" +
                                  std::to_string(toInt(size.substr(0, x), "--size width", 1)));
            c.overrides.push_back("render.height=" +
                                  std::to_string(toInt(size.substr(x + 1), "--size height", 1)));
        } else if (a == "--camera") {
            c.overrides.push_back("render.camera_position=" + tomlArray(next(args, i)));
        } else if (a == "--look-at") {
            c.overrides.push_back("render.look_at=" + tomlArray(next(args, i)));
        } else if (a == "--fov") {
            c.overrides.push_back("render.fov_deg=" + next(args, i));
        } else if (a == "--contact-frames") {
            c.overrides.push_back("render.contact_frames=" + next(args, i));
        } else if (a == "--frames") {
            parseFrames(next(args, i), c.options);
        } else if (a == "--no-video") {
            c.options.video = false;
        } else if (a == "--threads") {
            c.options.threads = toInt(next(args, i), "--threads", 1);
        } else if (a == "--quiet") {
            c.options.quiet = true;
        } else if (!a.empty() && a[0] == '-') {
            throw std::invalid_argument("unknown option '" + a + "' for firn render");
        } else if (c.outDir.empty()) {
            c.outDir = a;
        } else {
            throw std::invalid_argument("one output folder only, got '" + c.outDir + "' and '" + a +
                                        "'");
        }
    }
    if (!c.help && c.outDir.empty())
        throw std::invalid_argument("firn render needs an output folder");
    return c;
}

int runRenderCommand(const RenderCommand& command) {
    const SceneDesc scene = loadScene(command.outDir + "/scene.toml", command.overrides);
    RenderOptions options = command.options;
    options.view = scene.render;
    options.dimension = scene.simulation.dimension;
    const RenderResult r = renderOutput(command.outDir, options);
    std::printf("%d frames -> %s (%.2f s per frame, colour %s %.3g..%.3g)\n", r.frames,
                r.directory.c_str(), r.secondsPerFrame, toString(options.view.colorBy),
                r.colorRange[0], r.colorRange[1]);
    for (const std::string& video : r.videos) std::printf("%s\n", video.c_str());
    return 0;
}

} // namespace firn::cli
