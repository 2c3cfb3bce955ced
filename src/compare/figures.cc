// summary.json values and metrics.csv curves of two runs, each against its tolerance.
#include <firn/compare.h>

#include <firn/errors.h>
#include <firn/io.h>

#include "report/metrics_table.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

namespace firn {
namespace {

/// A summary.json value: a number, or text (strings, true/false/null as written).
struct JsonValue {
    bool isNumber = false;
    double number = 0.0;
    std::string text; ///< numbers: as written
};

/// Reads summary.json: an object of numbers, strings, booleans and nulls (outputs.md), and of
/// arrays and objects (slab_fractures), which are kept as their text and compared as text.
class FlatJsonReader {
public:
    FlatJsonReader(std::string text, std::string path)
        : mText(std::move(text))
        , mPath(std::move(path)) {}

    std::vector<std::pair<std::string, JsonValue>> read() {
        std::vector<std::pair<std::string, JsonValue>> items;
        expect('{');
        skipSpace();
        if (peek() == '}') return items;
        for (;;) {
            std::string key = readString();
            expect(':');
            items.emplace_back(std::move(key), readValue());
            skipSpace();
            if (peek() == ',') {
                ++mAt;
                continue;
            }
            expect('}');
            return items;
        }
    }

private:
    std::string mText, mPath;
    std::size_t mAt = 0;

    [[noreturn]] void fail(const std::string& what) const {
        throw IoError(mPath + ": not a flat JSON object at character " + std::to_string(mAt) +
                      ": " + what);
    }
    void skipSpace() {
        while (mAt < mText.size() && std::strchr(" \t\r\n", mText[mAt])) ++mAt;
    }
    char peek() const { return mAt < mText.size() ? mText[mAt] : '\0'; }
    void expect(char c) {
        skipSpace();
        if (peek() != c) fail(std::string("expected '") + c + "'");
        ++mAt;
    }
    std::string readString() {
        expect('"');
        std::string out;
        while (peek() != '"') {
            if (mAt >= mText.size()) fail("unterminated string");
            char c = mText[mAt++];
            if (c == '\\') {
                const char e = peek();
                ++mAt;
                c = e == 'n' ? '\n' : e == 't' ? '\t' : e;
                if (e == 'u') { // not written by Firn; kept as the escape text
                    out += "\\u";
                    continue;
                }
            }
            out += c;
        }
        ++mAt;
        return out;
    }
    /// Past a balanced [...] or {...}, strings inside included.
    void skipNested() {
        int depth = 0;
        do {
            if (mAt >= mText.size()) fail("unterminated array or object");
            const char c = mText[mAt];
            if (c == '"') {
                readString();
                continue;
            }
            depth += (c == '[' || c == '{') ? 1 : (c == ']' || c == '}') ? -1 : 0;
            ++mAt;
        } while (depth > 0);
    }
    JsonValue readValue() {
        skipSpace();
        JsonValue v;
        if (peek() == '"') {
            v.text = "\"" + readString() + "\"";
            return v;
        }
        const std::size_t start = mAt;
        if (peek() == '[' || peek() == '{') {
            skipNested();
            v.text = mText.substr(start, mAt - start);
            return v;
        }
        while (mAt < mText.size() && !std::strchr(",} \t\r\n", mText[mAt])) ++mAt;
        v.text = mText.substr(start, mAt - start);
        if (v.text == "true" || v.text == "false" || v.text == "null") return v;
        std::size_t used = 0;
        try {
            v.number = std::stod(v.text, &used);
        } catch (const std::exception&) {
            used = 0;
        }
        if (v.text.empty() || used != v.text.size()) fail("bad value '" + v.text + "'");
        v.isNumber = true;
        return v;
    }
};

std::vector<std::pair<std::string, JsonValue>> readSummary(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError("cannot read " + path + " (is its folder written by `firn run`?)");
    std::ostringstream text;
    text << in.rdbuf();
    return FlatJsonReader(text.str(), path).read();
}

/// Measurements of the machine and the run, not results: listed, never a reason to fail. So are
/// the messages and settle_overloaded_by_material, the words and the breakdown of figures that
/// are compared as numbers (settle_overloaded_particles and its box).
bool isInformational(const std::string& key) {
    static const std::set<std::string> keys = {"scene",
                                               "threads",
                                               "wall_seconds",
                                               "particle_steps_per_second",
                                               "peak_rss_bytes",
                                               "bytes_per_particle",
                                               "baseline_rss_bytes",
                                               "settle_wall_seconds",
                                               "settle_overloaded_by_material",
                                               "checkpoints_written",
                                               "checkpoint_wall_seconds",
                                               "resumed_from_frame",
                                               "rasters",
                                               "raster_wall_seconds"};
    const bool isMessage = key.size() >= 7 && key.compare(key.size() - 7, 7, "message") == 0;
    return keys.count(key) > 0 || isMessage;
}

bool withinTolerance(double absChange, double relChange, const Tolerance& t) {
    return (t.absolute ? absChange : relChange) <= t.value;
}

double relative(double change, double scale) {
    return scale > 0 ? change / scale : (change > 0 ? INFINITY : 0.0);
}

FigureComparison compareValue(const std::string& key, const JsonValue* a, const JsonValue* b,
                              const ToleranceTable& tolerances) {
    FigureComparison f;
    f.source = "summary";
    f.name = key;
    f.a = a ? a->text : "";
    f.b = b ? b->text : "";
    f.tolerance = tolerances.lookup(key);
    f.checked = !isInformational(key);
    if (!a || !b) {
        // A key that only one version writes: nothing to compare it with.
        f.checked = false;
        f.note = std::string("only in run ") + (a ? "A" : "B");
        return f;
    }
    f.identical = a->text == b->text;
    if (a->isNumber && b->isNumber) {
        f.absChange = std::abs(b->number - a->number);
        f.relChange = relative(f.absChange, std::max(std::abs(a->number), std::abs(b->number)));
        f.moved = f.checked && !withinTolerance(f.absChange, f.relChange, f.tolerance);
    } else {
        f.absChange = f.relChange = f.identical ? 0.0 : INFINITY;
        f.moved = f.checked && !f.identical;
    }
    return f;
}

/// Columns that key or time the rows rather than measure the run.
bool isCurve(const std::string& column) {
    return column != "frame" && column != "wall_seconds";
}

bool sameBits(double x, double y) {
    return std::memcmp(&x, &y, sizeof x) == 0;
}

FigureComparison compareCurve(const std::string& column, const std::vector<double>& a,
                              const std::vector<double>& b, const std::vector<double>& times,
                              const ToleranceTable& tolerances) {
    FigureComparison f;
    f.source = "metrics";
    f.name = column;
    f.tolerance = tolerances.lookup(column);
    double peakA = 0, peakB = 0, worstTime = NAN;
    int definedInOneOnly = -1;
    f.identical = true;
    for (std::size_t i = 0; i < a.size(); ++i) {
        f.identical = f.identical && sameBits(a[i], b[i]);
        const bool finiteA = std::isfinite(a[i]), finiteB = std::isfinite(b[i]);
        if (finiteA) peakA = std::max(peakA, std::abs(a[i]));
        if (finiteB) peakB = std::max(peakB, std::abs(b[i]));
        if (finiteA != finiteB && definedInOneOnly < 0) definedInOneOnly = int(i);
        if (finiteA && finiteB && std::abs(b[i] - a[i]) > f.absChange) {
            f.absChange = std::abs(b[i] - a[i]);
            worstTime = times[i];
        }
    }
    f.a = formatNumber(peakA);
    f.b = formatNumber(peakB);
    f.relChange = relative(f.absChange, std::max(peakA, peakB));
    if (definedInOneOnly >= 0) {
        // An empty cell on one side only (a crack in one run, none in the other) is a change
        // no tolerance covers.
        f.absChange = f.relChange = INFINITY;
        f.note = "a value in one run only from t = " + formatNumber(times[definedInOneOnly]) + " s";
    } else if (f.absChange > 0) {
        f.note = "largest change at t = " + formatNumber(worstTime) + " s";
    }
    f.moved = !withinTolerance(f.absChange, f.relChange, f.tolerance);
    return f;
}

std::vector<FigureComparison> compareMetrics(const std::string& pathA, const std::string& pathB,
                                             const ToleranceTable& tolerances) {
    const report::MetricsTable a = report::readMetrics(pathA), b = report::readMetrics(pathB);
    // Rows of the frames both runs reached, in frame order.
    std::map<int, std::pair<std::size_t, std::size_t>> common;
    const auto& framesA = a.column("frame");
    const auto& framesB = b.column("frame");
    std::map<int, std::size_t> rowOfB;
    for (std::size_t r = 0; r < b.rows; ++r) rowOfB[int(framesB[r])] = r;
    for (std::size_t r = 0; r < a.rows; ++r) {
        const auto it = rowOfB.find(int(framesA[r]));
        if (it != rowOfB.end()) common[int(framesA[r])] = {r, it->second};
    }
    std::vector<double> times;
    for (const auto& [frame, rows] : common) times.push_back(a.column("time")[rows.first]);

    std::vector<FigureComparison> figures;
    for (const auto& [column, valuesA] : a.columns) {
        if (!isCurve(column)) continue;
        const auto inB = b.columns.find(column);
        if (inB == b.columns.end()) {
            FigureComparison f;
            f.source = "metrics";
            f.name = column;
            f.checked = false;
            f.note = "only in run A";
            figures.push_back(f);
            continue;
        }
        std::vector<double> x, y;
        for (const auto& [frame, rows] : common) {
            x.push_back(valuesA[rows.first]);
            y.push_back(inB->second[rows.second]);
        }
        figures.push_back(compareCurve(column, x, y, times, tolerances));
        if (a.rows != b.rows) {
            figures.back().note += (figures.back().note.empty() ? "" : "; ") +
                                   std::to_string(common.size()) + " common frames";
        }
    }
    for (const auto& [column, values] : b.columns) {
        if (!isCurve(column) || a.columns.count(column)) continue;
        FigureComparison f;
        f.source = "metrics";
        f.name = column;
        f.checked = false;
        f.note = "only in run B";
        figures.push_back(f);
    }
    return figures;
}

} // namespace

std::vector<FigureComparison> compareFigures(const std::string& runA, const std::string& runB,
                                             const ToleranceTable& tolerances) {
    const auto a = readSummary(runA + "/summary.json");
    const auto b = readSummary(runB + "/summary.json");
    std::vector<FigureComparison> figures;
    auto find = [](const auto& items, const std::string& key) -> const JsonValue* {
        for (const auto& [k, v] : items)
            if (k == key) return &v;
        return nullptr;
    };
    for (const auto& [key, value] : a)
        figures.push_back(compareValue(key, &value, find(b, key), tolerances));
    for (const auto& [key, value] : b)
        if (!find(a, key)) figures.push_back(compareValue(key, nullptr, &value, tolerances));
    const auto curves = compareMetrics(runA + "/metrics.csv", runB + "/metrics.csv", tolerances);
    figures.insert(figures.end(), curves.begin(), curves.end());
    return figures;
}

} // namespace firn
