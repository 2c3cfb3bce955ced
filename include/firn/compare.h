// `firn compare RUN_A RUN_B`: two runs of one scene (two versions of Firn, or one changed
// parameter) side by side. The C++ side diffs the scenes, compares the caches bit for bit, the
// summary values and the metrics curves against tolerances, renders both runs with one camera
// and one colour range and takes their difference images; render/compare.py draws the overlaid
// curves and the failure maps and writes compare.html.
#pragma once

#include <firn/render.h>

#include <array>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace firn {

/// How far a figure may move before it counts as moved: a fraction of its size (relative) or
/// an amount in its own unit (absolute).
struct Tolerance {
    double value = 0.01;
    bool absolute = false;
};

/// Tolerances by figure name (a summary.json key, a metrics.csv column, or "pixels" for the
/// rendered frames); names without an entry get `fallback`.
struct ToleranceTable {
    std::map<std::string, Tolerance> byName;
    Tolerance fallback;

    /// The documented defaults (docs/review.md, `firn compare --help`).
    static ToleranceTable defaults();
    const Tolerance& lookup(const std::string& name) const;
    /// Applies "name=0.05" (relative), "name=abs:0.2" (absolute), or "all=..." (every figure,
    /// the defaults and earlier entries included). Throws std::invalid_argument with a message
    /// on a bad spec.
    void set(const std::string& spec);
};

/// One key path that differs between the two scene.toml files.
struct SceneDifference {
    std::string key;         ///< e.g. "material.snow.friction_angle", "body[1].min"
    std::string a, b;        ///< the values as TOML text; "(absent)" when a side lacks the key
    bool structural = false; ///< makes the runs different scenes (refused without --force)
};

/// Parses both scene.toml files and lists the keys that differ. Arrays of tables are matched
/// by their `name` when they have one (material.snow.x), else by position (body[0].x).
/// output.directory is ignored (where a run was written says nothing about what ran).
/// Structural: a different dimension, a different number of materials, bodies, terrains or
/// cuts, or an entity of another kind (its model, shape, material, file or layer). Everything
/// else (numbers, names, the transfer scheme, keys that only one version writes) is a
/// parameter difference: the same scene, listed. Throws SceneError (syntax, with the
/// location) or IoError (unreadable file).
std::vector<SceneDifference> diffScenes(const std::string& sceneA, const std::string& sceneB);

/// One compared figure: a summary value, a metrics curve, or the rendered frames.
struct FigureComparison {
    std::string source; ///< "summary", "metrics" or "frames"
    std::string name;   ///< the key, the column, or "pixels"
    std::string a, b;   ///< the values as text (curves: their peak magnitude)
    /// Summary: |b - a|. Curves: the largest |b - a| over the common frames. Frames: the
    /// largest fraction of pixels that differ.
    double absChange = 0.0;
    /// absChange over the larger magnitude of the two (summary) or of the two curves' peaks
    /// (curves); 0 when both are 0. Frames: equal to absChange.
    double relChange = 0.0;
    Tolerance tolerance;
    bool checked = true; ///< false: shown for information only (timings, thread counts)
    bool identical = false;
    bool moved = false; ///< checked and beyond tolerance (or a text value that differs)
    std::string note;   ///< what else to say (a frame count, a value present on one side only)
};

/// The rendered frames of one frame number, side by side.
struct FrameComparison {
    int frame = 0;
    double changedFraction = 0.0; ///< of the pixels, some channel differs by > kPixelThreshold
    int maxChannelDifference = 0; ///< 0..255
};

/// A pixel differs when one of its channels differs by more than this (of 255): a one-level
/// rounding difference is not a change.
constexpr int kPixelThreshold = 8;

/// Per pixel |a - b| as a heat image: exactly black where a and b are equal, brighter with the
/// largest channel difference (saturating at 64 levels). Throws std::invalid_argument when
/// the sizes differ.
Image differenceImage(const Image& a, const Image& b);

/// Fraction of pixels whose channels differ by more than kPixelThreshold, and the largest
/// channel difference. Same sizes required, as above.
FrameComparison compareImages(const Image& a, const Image& b);

/// The particle and volume caches of two runs, frame for frame.
struct CacheComparison {
    bool identical = false;   ///< same frames, and every grid value and attribute bitwise equal
    std::vector<int> frames;  ///< frame numbers present in both
    std::vector<int> onlyInA; ///< frame numbers of one run only
    std::vector<int> onlyInB;
    std::string firstDifference; ///< e.g. "frames/particles.0003.vdb: attribute v", empty if none
};

/// Compares RUN_A/frames and RUN_B/frames (particles and volumes). Throws IoError on an
/// unreadable file.
CacheComparison compareCaches(const std::string& runA, const std::string& runB);

/// summary.json (a flat object) and metrics.csv of both runs against `tolerances`. Timings,
/// thread counts and memory are listed with checked = false.
std::vector<FigureComparison> compareFigures(const std::string& runA, const std::string& runB,
                                             const ToleranceTable& tolerances);

struct CompareOptions {
    std::string runA, runB;
    std::string outDir; ///< empty: RUN_B/compare
    bool force = false; ///< compare different scenes all the same
    ToleranceTable tolerances = ToleranceTable::defaults();
    /// render.<key>=<value> overrides on top of RUN_A's [render] (colour, range, size).
    std::vector<std::string> renderOverrides;
    int frameStep = 1;  ///< render every n-th common frame
    int threads = 0;    ///< 0 = all cores
    bool quiet = false; ///< no progress lines on stderr
};

struct CompareResult {
    /// "identical": caches, figures and renders bitwise equal; "within tolerance"; "moved".
    std::string verdict;
    std::vector<SceneDifference> sceneDifferences;
    CacheComparison caches;
    std::vector<FigureComparison> figures;
    std::vector<FrameComparison> frames;
    std::array<double, 2> colorRange{0.0, 1.0};
    std::string page; ///< compare.html

    /// 0 when nothing moved beyond tolerance, 5 otherwise.
    int exitCode() const { return verdict == "moved" ? 5 : 0; }
    /// A few lines for stdout: the verdict, then each figure that moved.
    std::string textSummary() const;
};

/// Thrown when the two runs are of different scenes and `force` is off; what() names the
/// differing keys.
class DifferentScenesError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

/// Compares two run folders and writes OUT_DIR/compare.html with its images. Throws
/// DifferentScenesError, IoError (missing files, the script failing) or SceneError.
CompareResult compareRuns(const CompareOptions& options);

} // namespace firn
