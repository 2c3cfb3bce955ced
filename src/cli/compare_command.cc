#include "compare_command.h"

#include <cstdio>
#include <stdexcept>

namespace firn::cli {

const char* const kCompareHelp = R"(usage: firn compare RUN_A RUN_B [options]

Compares two output folders of `firn run` of the same scene (two versions of Firn, or one
changed parameter) and writes OUT/compare.html (self-contained, images embedded) with: both runs
rendered side by side with one camera and one colour range, a difference image per frame and a
contact sheet; the metrics.csv curves of both overlaid; the summary.json values with their
absolute and relative change; the failure maps of both when the scene has a weak layer; and the
differences between the two scene.toml files. Prints the verdict and what moved.

Runs of different scenes (another dimension, other bodies, terrains, materials or cuts) are
refused; changed values of the same scene are listed. output.directory is ignored.

A figure is a summary.json value, a metrics.csv curve (compared over the frames both runs have:
its largest change, relative to the larger of the two peaks) or "pixels" (the largest share of
a rendered frame's pixels that differ by more than 8 of 255 levels in a channel).
Default tolerances: 1 % (relative); mass, mass_initial, mass_final 1e-6; time 1e-9;
crack_speed, max_crack_speed, mean_crack_speed, energy_drift 5 %; alpha_angle_deg 0.5 degrees
(absolute); pixels 1 %. Timings, threads and memory are listed, never compared.

options:
  --out DIR               where compare.html and its images go (default RUN_B/compare)
  --force                 compare runs of different scenes all the same
  --tolerance NAME=V      relative tolerance of a figure, e.g. max_speed=0.05 (5 %)
  --tolerance NAME=abs:V  absolute tolerance, in the figure's unit, e.g. runout_x=abs:0.2
                          NAME all: every figure (the defaults too); repeatable
  --color-by Q            density | speed | failed | eta (default: RUN_A's [render], speed)
  --color-range LO,HI     colour range of both renders (default 0 to the larger maximum)
  --size WxH              size of each rendered frame (default 640x360)
  --frame-step N          render every N-th common frame (default 1)
  --threads N             worker threads for the renders (default: all cores)
  --quiet                 no progress lines on stderr
  -h, --help              this text

Exit codes: 0 every figure within tolerance (the verdict says "identical" when the caches,
values and renders are bitwise equal), 5 a figure moved beyond its tolerance, 1 usage error or
different scenes, 3 I/O error.
)";

namespace {

std::string next(const std::vector<std::string>& args, std::size_t& i) {
    if (i + 1 >= args.size()) throw std::invalid_argument(args[i] + " needs a value");
    return args[++i];
}

int positiveInt(const std::string& text, const std::string& option) {
    std::size_t used = 0;
    int value = 0;
    try {
        value = std::stoi(text, &used);
    } catch (const std::exception&) {
        used = 0;
    }
    if (used == 0 || used != text.size() || value < 1)
        throw std::invalid_argument(option + " must be an integer >= 1, got '" + text + "'");
    return value;
}

} // namespace

CompareCommand parseCompareCommand(const std::vector<std::string>& args) {
    CompareCommand c;
    CompareOptions& o = c.options;
    std::vector<std::string> runs;
    std::string size = "640x360";
    for (std::size_t i = 0; i < args.size(); ++i) {
        const std::string& a = args[i];
        if (a == "-h" || a == "--help") {
            c.help = true;
        } else if (a == "--out") {
            o.outDir = next(args, i);
        } else if (a == "--force") {
            o.force = true;
        } else if (a == "--tolerance") {
            o.tolerances.set(next(args, i));
        } else if (a == "--color-by") {
            o.renderOverrides.push_back("render.color_by=\"" + next(args, i) + "\"");
        } else if (a == "--color-range") {
            o.renderOverrides.push_back("render.color_range=[" + next(args, i) + "]");
        } else if (a == "--size") {
            size = next(args, i);
        } else if (a == "--frame-step") {
            o.frameStep = positiveInt(next(args, i), "--frame-step");
        } else if (a == "--threads") {
            o.threads = positiveInt(next(args, i), "--threads");
        } else if (a == "--quiet") {
            o.quiet = true;
        } else if (!a.empty() && a[0] == '-') {
            throw std::invalid_argument("unknown option '" + a + "' for firn compare");
        } else {
            runs.push_back(a);
        }
    }
    if (c.help) return c;
    if (runs.size() != 2) {
        throw std::invalid_argument("firn compare needs two output folders (RUN_A RUN_B), got " +
                                    std::to_string(runs.size()));
    }
    o.runA = runs[0];
    o.runB = runs[1];
    const std::size_t x = size.find('x');
    if (x == std::string::npos)
        throw std::invalid_argument("--size takes WIDTHxHEIGHT, e.g. 640x360; got '" + size + "'");
    o.renderOverrides.push_back("render.width=" +
                                std::to_string(positiveInt(size.substr(0, x), "--size width")));
    o.renderOverrides.push_back("render.height=" +
                                std::to_string(positiveInt(size.substr(x + 1), "--size height")));
    return c;
}

int runCompareCommand(const CompareCommand& command) {
    const CompareResult r = compareRuns(command.options);
    std::fputs(r.textSummary().c_str(), stdout);
    std::printf("%s\n", r.page.c_str());
    return r.exitCode();
}

} // namespace firn::cli
