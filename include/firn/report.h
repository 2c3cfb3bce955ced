// `firn report`: an HTML report of a finished run (failure maps of the weak layer, crack tip and
// speed, flow speed and energy, the McClung & Gauer diagram, the summary table). The C++ side
// reduces the particle caches to small CSV tables; render/report.py draws them.
#pragma once

#include <string>
#include <vector>

namespace firn {

struct ReportOptions {
    std::string outDir;        ///< a folder written by `firn run`
    std::vector<double> times; ///< s, for the failure maps; empty: automatic
    bool quiet = false;        ///< no progress output
};

/// Writes the tables behind the report's charts (weak_layer.csv, map_frames.csv, report.json)
/// into `dataDir`, without drawing them. Returns the failure maps' times (s), so that another
/// run can be mapped at the same times (`firn compare`). Throws like writeReport.
std::vector<double> writeReportTables(const ReportOptions& options, const std::string& dataDir);

/// Writes OUT_DIR/report/data/*.csv and report.json, then runs render/report.py, which writes
/// OUT_DIR/report/*.png and report.html. Returns report.html's path. Throws IoError (missing or
/// unreadable files, the script failing) or SceneError (bad scene.toml, a time outside the run).
std::string writeReport(const ReportOptions& options);

} // namespace firn
