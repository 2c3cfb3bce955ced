// `firn compare RUN_A RUN_B`: scene check, caches, figures, renders with one camera and one
// colour range, difference images; then render/compare.py writes compare.html.
#include <firn/compare.h>

#include <firn/errors.h>
#include <firn/io.h>
#include <firn/report.h>
#include <firn/scene.h>

#include "compare/frame_images.h"
#include "report/python_script.h"

#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace firn {
namespace {

namespace fs = std::filesystem;

void progress(const CompareOptions& options, const std::string& line) {
    if (!options.quiet) std::fprintf(stderr, "firn compare: %s\n", line.c_str());
}

void requireRunFolder(const std::string& dir) {
    std::error_code error;
    if (!fs::is_regular_file(fs::path(dir) / "scene.toml", error)) {
        throw IoError(dir + ": no scene.toml (give two output folders of `firn run`)");
    }
}

/// The dimension and [render] of RUN_A's scene.toml with the command's render overrides on top.
/// Only those two are parsed: another version's scene.toml may hold keys this one rejects.
SceneDesc readRenderScene(const std::string& runDir, const std::vector<std::string>& overrides) {
    const std::string path = runDir + "/scene.toml";
    toml::table root;
    try {
        root = toml::parse_file(path);
    } catch (const toml::parse_error& e) {
        const auto& at = e.source().begin;
        throw SceneError(SourceLoc{path, int(at.line), int(at.column)}, "syntax",
                         std::string(e.description()));
    }
    toml::table kept;
    toml::table simulation;
    simulation.insert("name", "compare");
    if (const auto dimension = root["simulation"]["dimension"].value<int64_t>())
        simulation.insert("dimension", *dimension);
    kept.insert("simulation", simulation);
    if (const auto* render = root["render"].as_table()) kept.insert("render", *render);
    std::ostringstream text;
    text << kept;
    return parseScene(text.str(), path, overrides);
}

/// Quotes a CSV cell when it holds a comma, a quote or a line break (RFC 4180).
std::string csvCell(const std::string& text) {
    if (text.find_first_of(",\"\n") == std::string::npos) return text;
    std::string quoted = "\"";
    for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
    return quoted + "\"";
}

std::string csvNumber(double value) {
    return std::isfinite(value) ? formatNumber(value) : (std::isnan(value) ? "" : "inf");
}

std::string frameName(const std::string& stem, int frame) {
    char name[48];
    std::snprintf(name, sizeof name, "%s.%04d.png", stem.c_str(), frame);
    return name;
}

/// What the renders of both runs share, and what came of them.
struct RenderPlan {
    RenderOptions options;
    std::array<double, 2> range{0.0, 1.0};
};

RenderPlan planRenders(const CompareOptions& options, int lastCommonFrame) {
    const SceneDesc scene = readRenderScene(options.runA, options.renderOverrides);
    RenderPlan plan;
    RenderOptions& o = plan.options;
    o.view = scene.render;
    o.dimension = scene.simulation.dimension;
    o.lastFrame = lastCommonFrame;
    o.frameStep = options.frameStep;
    o.threads = options.threads;
    o.video = false;
    o.quiet = options.quiet;
    const VolumeCacheExtent a = scanVolumeCache(options.runA, o);
    const VolumeCacheExtent b = scanVolumeCache(options.runB, o);
    const bool userRange =
        std::isfinite(o.view.colorRange[0]) && std::isfinite(o.view.colorRange[1]);
    if (userRange) {
        plan.range = o.view.colorRange;
    } else if (o.view.colorBy == ColorBy::Failed) {
        plan.range = {0.0, 1.0};
    } else {
        const double top = std::max(a.maxValue, b.maxValue);
        plan.range = {0.0, top > 0 ? top : 1.0};
    }
    o.view.colorRange = plan.range;
    o.opaqueDensity = std::max(a.maxDensity, b.maxDensity);
    if (o.view.autoCamera) {
        Box3 box = a.box;
        for (int k = 0; k < 3; ++k) {
            box.min[k] = std::min(a.box.min[k], b.box.min[k]);
            box.max[k] = std::max(a.box.max[k], b.box.max[k]);
        }
        o.camera = frameBox(box, o.dimension, o.view.width, o.view.height, o.view.fovDeg);
    }
    return plan;
}

/// Renders both runs into OUT/a and OUT/b, then writes OUT/diff/diff.NNNN.png,
/// OUT/pairs/pair.NNNN.png and OUT/contact.png. Returns one comparison per rendered frame.
std::vector<FrameComparison> renderAndDiff(const CompareOptions& options, const std::string& out,
                                           RenderPlan& plan) {
    RenderOptions o = plan.options;
    o.directory = out + "/a";
    progress(options, "rendering " + options.runA);
    const RenderResult a = renderOutput(options.runA, o);
    o.directory = out + "/b";
    progress(options, "rendering " + options.runB);
    renderOutput(options.runB, o);

    makeDirectories(out + "/diff");
    makeDirectories(out + "/pairs");
    std::vector<FrameComparison> frames;
    std::vector<Image> sheet;
    const int sheetRows = std::min(6, a.frames);
    for (const auto& entry : fs::directory_iterator(out + "/a")) {
        const std::string name = entry.path().filename().string();
        if (name.rfind("frame.", 0) != 0) continue;
        const int frame = std::stoi(name.substr(6, name.size() - 10));
        const std::string pathB = out + "/b/" + name;
        std::error_code error;
        if (!fs::exists(pathB, error)) continue; // a frame the other run does not have
        const Image imageA = readPng(entry.path().string()), imageB = readPng(pathB);
        FrameComparison c = compareImages(imageA, imageB);
        c.frame = frame;
        frames.push_back(c);
        const Image diff = differenceImage(imageA, imageB);
        writePng(out + "/diff/" + frameName("diff", frame), diff);
        writePng(out + "/pairs/" + frameName("pair", frame),
                 compare::sideBySide({imageA, imageB, diff}, {"run a", "run b", "a - b"}));
    }
    std::sort(frames.begin(), frames.end(),
              [](const FrameComparison& x, const FrameComparison& y) { return x.frame < y.frame; });
    // The contact sheet: evenly spaced pairs, first and last included.
    for (int r = 0; r < sheetRows && !frames.empty(); ++r) {
        const std::size_t at =
            sheetRows == 1
                ? frames.size() - 1
                : std::size_t(std::lround(double(r) * (frames.size() - 1) / (sheetRows - 1)));
        sheet.push_back(readPng(out + "/pairs/" + frameName("pair", frames[at].frame)));
    }
    if (!sheet.empty()) {
        const double scale = std::min(1.0, 1400.0 / sheet.front().width);
        writePng(out + "/contact.png", contactSheet(sheet, 1, scale));
    }
    return frames;
}

FigureComparison pixelFigure(const std::vector<FrameComparison>& frames,
                             const ToleranceTable& tolerances) {
    FigureComparison f;
    f.source = "frames";
    f.name = "pixels";
    f.tolerance = tolerances.lookup("pixels");
    f.identical = true;
    int differing = 0, worst = -1;
    for (const FrameComparison& c : frames) {
        f.identical = f.identical && c.maxChannelDifference == 0;
        if (c.changedFraction > 0) ++differing;
        if (c.changedFraction > f.absChange) {
            f.absChange = c.changedFraction;
            worst = c.frame;
        }
    }
    f.relChange = f.absChange;
    f.a = f.b = std::to_string(frames.size()) + " frames";
    f.note = std::to_string(differing) + " of " + std::to_string(frames.size()) +
             " frames have changed pixels";
    if (worst >= 0) f.note += "; most in frame " + std::to_string(worst);
    f.moved = f.absChange > f.tolerance.value;
    return f;
}

/// Weak-layer tables of both runs for the failure maps (render/report.py draws them), at the
/// same times when run B reaches them. Returns "" or why there are no maps.
std::string writeMapTables(const CompareOptions& options, const std::string& dataDir) {
    ReportOptions report;
    report.quiet = true;
    try {
        report.outDir = options.runA;
        const std::vector<double> times = writeReportTables(report, dataDir + "/a");
        report.outDir = options.runB;
        report.times = times;
        try {
            writeReportTables(report, dataDir + "/b");
        } catch (const SceneError&) {
            report.times.clear(); // run B ends before A's map times: its own times
            writeReportTables(report, dataDir + "/b");
        }
    } catch (const FirnError& e) {
        return std::string("no failure maps: ") + e.what();
    }
    return "";
}

void writeTables(const CompareResult& r, const CompareOptions& options, const std::string& out,
                 const std::string& mapsNote, const std::string& renderNote) {
    const std::string data = out + "/data";
    std::string scene = "key,a,b,structural\n";
    for (const SceneDifference& d : r.sceneDifferences) {
        scene += csvCell(d.key) + "," + csvCell(d.a) + "," + csvCell(d.b) + "," +
                 (d.structural ? "1" : "0") + "\n";
    }
    writeFileAtomic(data + "/scene_diff.csv", scene);
    std::string figures =
        "source,name,a,b,abs_change,rel_change,tolerance,absolute,checked,identical,moved,note\n";
    for (const FigureComparison& f : r.figures) {
        figures += f.source + "," + csvCell(f.name) + "," + csvCell(f.a) + "," + csvCell(f.b) +
                   "," + csvNumber(f.absChange) + "," + csvNumber(f.relChange) + "," +
                   csvNumber(f.tolerance.value) + "," + (f.tolerance.absolute ? "1" : "0") + "," +
                   (f.checked ? "1" : "0") + "," + (f.identical ? "1" : "0") + "," +
                   (f.moved ? "1" : "0") + "," + csvCell(f.note) + "\n";
    }
    writeFileAtomic(data + "/figures.csv", figures);
    std::string frames = "frame,changed_fraction,max_channel_difference\n";
    for (const FrameComparison& c : r.frames) {
        frames += std::to_string(c.frame) + "," + csvNumber(c.changedFraction) + "," +
                  std::to_string(c.maxChannelDifference) + "\n";
    }
    writeFileAtomic(data + "/frames.csv", frames);
    JsonObject json;
    json.set("run_a", fs::absolute(options.runA).lexically_normal().string());
    json.set("run_b", fs::absolute(options.runB).lexically_normal().string());
    json.set("verdict", r.verdict);
    json.setBool("caches_identical", r.caches.identical);
    json.set("cache_difference", r.caches.firstDifference);
    json.set("frames_only_in_a", int(r.caches.onlyInA.size()));
    json.set("frames_only_in_b", int(r.caches.onlyInB.size()));
    json.set("color_range_low", r.colorRange[0]);
    json.set("color_range_high", r.colorRange[1]);
    json.set("pixel_threshold", kPixelThreshold);
    json.set("maps_note", mapsNote);
    json.set("render_note", renderNote);
    writeFileAtomic(data + "/compare.json", json.str());
}

std::string verdictOf(const CompareResult& r) {
    const bool anyMoved = std::any_of(r.figures.begin(), r.figures.end(),
                                      [](const FigureComparison& f) { return f.moved; });
    if (anyMoved) return "moved";
    const bool allIdentical =
        r.caches.identical && std::all_of(r.figures.begin(), r.figures.end(),
                                          [](const auto& f) { return !f.checked || f.identical; });
    return allIdentical ? "identical" : "within tolerance";
}

std::string percent(double fraction) {
    if (!std::isfinite(fraction)) return "inf";
    char text[32];
    std::snprintf(text, sizeof text, "%.3g %%", 100.0 * fraction);
    return text;
}

/// A number written by summary.json, shortened to 6 significant digits; other text as it is.
std::string shortNumber(const std::string& text) {
    char* end = nullptr;
    const double value = std::strtod(text.c_str(), &end);
    if (text.empty() || *end != '\0') return text;
    char shortened[32];
    std::snprintf(shortened, sizeof shortened, "%.6g", value);
    return shortened;
}

} // namespace

std::string CompareResult::textSummary() const {
    std::string text = verdict;
    if (verdict == "identical") {
        text += ": caches, summary, metrics and renders are bitwise equal\n";
    } else {
        int moved = 0, checked = 0;
        for (const FigureComparison& f : figures) moved += f.moved, checked += f.checked;
        text += ": " + std::to_string(moved) + " of " + std::to_string(checked) +
                " compared figures beyond tolerance" +
                (caches.identical ? "" : "; caches differ (" + caches.firstDifference + ")") + "\n";
    }
    for (const FigureComparison& f : figures) {
        if (!f.moved) continue;
        const std::string change =
            f.tolerance.absolute ? formatNumber(f.absChange) : percent(f.relChange);
        const std::string tolerance =
            f.tolerance.absolute ? formatNumber(f.tolerance.value) : percent(f.tolerance.value);
        text += "  moved " + f.source + " " + f.name + ": ";
        if (f.source == "summary")
            text += shortNumber(f.a) + " -> " + shortNumber(f.b) + ", change " + change;
        else if (f.source == "metrics")
            text += change + (f.tolerance.absolute ? "" : " of the peak");
        else
            text += "up to " + change + " of a frame's pixels differ";
        text += " (tolerance " + tolerance + ")" + (f.note.empty() ? "" : "; " + f.note) + "\n";
    }
    for (const SceneDifference& d : sceneDifferences)
        text += "  scene " + d.key + ": " + d.a + " -> " + d.b + "\n";
    return text;
}

CompareResult compareRuns(const CompareOptions& options) {
    requireRunFolder(options.runA);
    requireRunFolder(options.runB);
    CompareResult r;
    r.sceneDifferences = diffScenes(options.runA + "/scene.toml", options.runB + "/scene.toml");
    std::string structural;
    for (const SceneDifference& d : r.sceneDifferences) {
        if (d.structural) structural += "\n  " + d.key + ": " + d.a + " vs " + d.b;
    }
    if (!structural.empty() && !options.force) {
        throw DifferentScenesError(options.runA + " and " + options.runB +
                                   " are runs of different scenes (scene.toml differs in" +
                                   structural + ")\nuse --force to compare them all the same");
    }
    const std::string out = options.outDir.empty() ? options.runB + "/compare" : options.outDir;
    makeDirectories(out + "/data");

    progress(options, "comparing the caches");
    r.caches = compareCaches(options.runA, options.runB);
    r.figures = compareFigures(options.runA, options.runB, options.tolerances);

    std::string renderNote;
    try {
        const int lastCommon = r.caches.frames.empty() ? -1 : r.caches.frames.back();
        RenderPlan plan = planRenders(options, lastCommon);
        r.colorRange = plan.range;
        r.frames = renderAndDiff(options, out, plan);
        r.figures.push_back(pixelFigure(r.frames, options.tolerances));
    } catch (const IoError& e) {
        // A run without a volume cache still has its figures compared.
        renderNote = std::string("no renders: ") + e.what();
    }
    progress(options, "reducing the weak layers for the failure maps");
    const std::string mapsNote = writeMapTables(options, out + "/data");
    r.verdict = verdictOf(r);
    writeTables(r, options, out, mapsNote, renderNote);

    const std::string script = report::renderScriptPath("compare.py");
    progress(options, "drawing charts with " + script);
    std::vector<std::string> args = {out};
    if (options.quiet) args.push_back("--quiet");
    report::runPythonScript(script, args);
    r.page = out + "/compare.html";
    return r;
}

} // namespace firn
