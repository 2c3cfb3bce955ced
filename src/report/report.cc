// `firn report`: reduces a run folder's particle caches to small tables, then hands them to
// render/report.py, which draws the charts and writes report.html.
#include <firn/report.h>

#include <firn/io.h>
#include <firn/scene.h>

#include "report/deposit_profile.h"
#include "report/map_frames.h"
#include "report/metrics_table.h"
#include "report/particle_reader.h"
#include "report/python_script.h"
#include "report/run_scene.h"
#include "report/weak_layer_map.h"

#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

namespace firn {
namespace {

namespace fs = std::filesystem;
using report::CachedFrame;

/// Float data carry about 7 significant digits; more would only make the tables longer.
std::string csvNumber(double value) {
    if (!std::isfinite(value)) return "";
    char text[32];
    std::snprintf(text, sizeof text, "%.7g", value);
    return text;
}

struct RunFolder {
    std::string outDir;
    SceneDesc scene;
    std::vector<report::WeakLayerMaterial> materials; ///< by material index
    std::string weakLayerNames;                       ///< comma-separated, empty when there is none
    report::MetricsTable metrics;
    std::vector<int> frames;      ///< particle cache frames that have a metrics row
    std::vector<double> times;    ///< s, of those frames
    std::vector<double> crackTip; ///< m, metrics.csv crack_tip_x of those frames

    std::string framePath(int frame) const {
        return outDir + "/frames/" + frameFileName("particles", frame);
    }
};

RunFolder openRunFolder(const std::string& outDir) {
    std::error_code error;
    if (!fs::is_directory(outDir, error)) {
        throw IoError(outDir + ": no such folder (give the output folder of `firn run`)");
    }
    RunFolder run;
    run.outDir = outDir;
    run.scene = report::loadRunScene(outDir + "/scene.toml");
    for (const MaterialDesc& m : run.scene.materials) {
        const bool weak = m.model == MaterialModel::WeakLayer;
        run.materials.push_back({weak, m.initialP0, m.criticalStateSlope, m.cohesionRatio});
        if (weak) run.weakLayerNames += (run.weakLayerNames.empty() ? "" : ",") + m.name;
    }
    run.metrics = report::readMetrics(outDir + "/metrics.csv");
    const auto& frameColumn = run.metrics.column("frame");
    const auto& timeColumn = run.metrics.column("time");
    const auto& tipColumn = run.metrics.column("crack_tip_x");
    std::map<int, std::size_t> rowOfFrame;
    for (std::size_t r = 0; r < run.metrics.rows; ++r) rowOfFrame[int(frameColumn[r])] = r;
    // A run stopped by a signal may hold a last frame file whose metrics row was never written.
    for (int frame : report::listParticleFrames(outDir + "/frames")) {
        const auto row = rowOfFrame.find(frame);
        if (row == rowOfFrame.end()) continue;
        run.frames.push_back(frame);
        run.times.push_back(timeColumn[row->second]);
        run.crackTip.push_back(tipColumn[row->second]);
    }
    return run;
}

class WeakLayerTable {
public:
    WeakLayerTable()
        : mText("frame,time,x,z,failed_fraction,eta,p,slab_speed,slab_failed_fraction,"
                "strength_used,slab_p\n") {}

    void add(const CachedFrame& frame, const std::vector<report::WeakLayerCell>& cells) {
        const std::string prefix =
            std::to_string(frame.info.frame) + "," + csvNumber(frame.info.time) + ",";
        for (const auto& c : cells) {
            mText += prefix + csvNumber(c.x) + "," + csvNumber(c.z) + "," +
                     csvNumber(c.failedFraction) + "," + csvNumber(c.eta) + "," + csvNumber(c.p) +
                     "," + csvNumber(c.slabSpeed) + "," + csvNumber(c.slabFailedFraction) + "," +
                     csvNumber(c.strengthUsed) + "," + csvNumber(c.slabP) + "\n";
        }
    }
    const std::string& text() const { return mText; }

private:
    std::string mText;
};

/// The release's highest point (first frame) and the deposit's farthest point along x (last
/// frame): the ends of the path that summary.json's alpha angle measures; and the snow's depth
/// along x in those two frames.
struct PathEnds {
    double topX = std::numeric_limits<double>::quiet_NaN(), topY = topX;
    double farX = topX, farY = topX;
    std::vector<report::DepthCell> depthStart, depthEnd;
    double startTime = std::numeric_limits<double>::quiet_NaN(), endTime = startTime; ///< s
};

/// deposit.csv: x (cell centre, m) and the snow's vertical depth there in the first and the last
/// particle frame (m; empty where that frame has no snow).
std::string depositCsv(const PathEnds& ends) {
    std::map<double, std::pair<double, double>> rows; // x -> (start, end)
    const double nan = std::numeric_limits<double>::quiet_NaN();
    for (const auto& c : ends.depthStart) rows.emplace(c.x, std::pair{c.depth, nan});
    for (const auto& c : ends.depthEnd)
        rows.try_emplace(c.x, nan, nan).first->second.second = c.depth;
    std::string text = "x,depth_start,depth_end\n";
    for (const auto& [x, depth] : rows)
        text += csvNumber(x) + "," + csvNumber(depth.first) + "," + csvNumber(depth.second) + "\n";
    return text;
}

void findTop(const ParticleFrame& f, PathEnds& ends) {
    for (std::size_t i = 0; i < f.P.size(); ++i) {
        if (!(f.P[i][1] <= ends.topY)) ends.topX = f.P[i][0], ends.topY = f.P[i][1];
    }
}

void findFar(const ParticleFrame& f, PathEnds& ends) {
    for (std::size_t i = 0; i < f.P.size(); ++i) {
        if (!(f.P[i][0] <= ends.farX)) ends.farX = f.P[i][0], ends.farY = f.P[i][1];
    }
}

bool contains(const std::vector<int>& frames, int frame) {
    return std::find(frames.begin(), frames.end(), frame) != frames.end();
}

void progress(const ReportOptions& options, const std::string& line) {
    if (!options.quiet) std::fprintf(stderr, "firn report: %s\n", line.c_str());
}

/// Reads the frames the report needs, in order: in 2D every frame (the maps are x-time images),
/// in 3D the mapped ones; always the first and the last, for the path ends.
void reduceFrames(const RunFolder& run, const std::vector<int>& mapFrames,
                  const ReportOptions& options, WeakLayerTable& table, PathEnds& ends) {
    const bool everyFrame = run.scene.simulation.dimension == 2;
    const bool hasWeakLayer = !run.weakLayerNames.empty();
    std::vector<int> toRead;
    for (int frame : run.frames) {
        if (everyFrame || contains(mapFrames, frame) || frame == run.frames.front() ||
            frame == run.frames.back())
            toRead.push_back(frame);
    }
    progress(options, "reading " + std::to_string(toRead.size()) + " particle frames");
    for (int frame : toRead) {
        const CachedFrame cached = report::readParticleFrame(run.framePath(frame));
        const double dx = run.scene.grid.dx;
        const int dim = run.scene.simulation.dimension, ppc = run.scene.grid.particlesPerCell;
        if (frame == run.frames.front()) {
            findTop(cached.particles, ends);
            ends.depthStart = report::snowDepthAlongX(cached.particles, dx, dim, ppc);
            ends.startTime = cached.info.time;
        }
        if (frame == run.frames.back()) {
            findFar(cached.particles, ends);
            ends.depthEnd = report::snowDepthAlongX(cached.particles, dx, dim, ppc);
            ends.endTime = cached.info.time;
        }
        // The first frame too: the static load before anything triggers (strength_used).
        if (hasWeakLayer &&
            (everyFrame || frame == run.frames.front() || contains(mapFrames, frame))) {
            table.add(cached,
                      report::binWeakLayer(cached.particles, run.materials, run.scene.grid.dx,
                                           run.scene.simulation.dimension));
        }
    }
}

std::string mapFramesCsv(const RunFolder& run, const std::vector<int>& mapFrames) {
    std::string text = "frame,time\n";
    for (int frame : mapFrames) {
        const auto at = std::find(run.frames.begin(), run.frames.end(), frame) - run.frames.begin();
        text += std::to_string(frame) + "," + formatNumber(run.times[at]) + "\n";
    }
    return text;
}

std::string reportJson(const RunFolder& run, const ReportOptions& options, const PathEnds& ends) {
    JsonObject json;
    json.set("dimension", run.scene.simulation.dimension);
    json.set("dx", run.scene.grid.dx);
    json.set("weak_layer_materials", run.weakLayerNames);
    json.set("particle_frames", int(run.frames.size()));
    json.set("map_times", options.times.empty() ? "automatic" : "requested");
    json.set("release_top_x", ends.topX);
    json.set("release_top_y", ends.topY);
    json.set("deposit_far_x", ends.farX);
    json.set("deposit_far_y", ends.farY);
    json.set("deposit_start_time", ends.startTime); // deposit.csv's two frames, s
    json.set("deposit_end_time", ends.endTime);
    return json.str();
}

} // namespace

std::vector<double> writeReportTables(const ReportOptions& options, const std::string& dataDir) {
    const RunFolder run = openRunFolder(options.outDir);
    if (!options.times.empty() && run.frames.empty()) {
        throw SceneError(SourceLoc{"--times", 0, 0}, "",
                         "the run wrote no particle cache (output.particles = false), so there "
                         "are no frames to map");
    }
    const std::vector<int> mapFrames = report::chooseMapFrames(run.frames, run.times, run.crackTip,
                                                               options.times, run.scene.grid.dx);
    WeakLayerTable table;
    PathEnds ends;
    if (!run.frames.empty()) reduceFrames(run, mapFrames, options, table, ends);

    makeDirectories(dataDir);
    writeFileAtomic(dataDir + "/weak_layer.csv", table.text());
    writeFileAtomic(dataDir + "/map_frames.csv", mapFramesCsv(run, mapFrames));
    writeFileAtomic(dataDir + "/report.json", reportJson(run, options, ends));
    writeFileAtomic(dataDir + "/deposit.csv", depositCsv(ends));
    std::vector<double> mapTimes;
    for (int frame : mapFrames) {
        const auto at = std::find(run.frames.begin(), run.frames.end(), frame) - run.frames.begin();
        mapTimes.push_back(run.times[at]);
    }
    return mapTimes;
}

std::string writeReport(const ReportOptions& options) {
    const std::string script = report::renderScriptPath("report.py");
    const std::string reportDir = options.outDir + "/report";
    writeReportTables(options, reportDir + "/data");
    progress(options, "drawing charts with " + script);
    std::vector<std::string> args = {options.outDir};
    if (options.quiet) args.push_back("--quiet");
    report::runPythonScript(script, args);
    return reportDir + "/report.html";
}

} // namespace firn
