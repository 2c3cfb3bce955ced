// firn: run, check scenes. Exit codes: 0 ok, 1 scene or usage error, 2 simulation unstable,
// 3 I/O or resource error, 4 internal error (a bug: please report), 5 `firn compare`: a figure
// moved beyond its tolerance, 130 interrupted (SIGINT/SIGTERM).
#include <firn/errors.h>
#include <firn/output_keys.h>
#include <firn/report.h>
#include <firn/resources.h>
#include <firn/run.h>
#include <firn/scene.h>
#include <firn/scene_keys.h>

#include "compare_command.h"
#include "render_command.h"

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <exception>
#include <fstream>
#include <new>
#include <sstream>
#include <string>
#include <vector>

namespace {

const char* kUsage = R"(firn - snow avalanche simulation with the material point method

usage:
  firn run SCENE.toml [--threads N] [--out DIR] [--set key=value ...] [--max-memory SIZE]
           [--checkpoint-every N|Mmin] [--quiet]
  firn run --resume OUT_DIR [--threads N] [--max-memory SIZE] [--checkpoint-every ...] [--quiet]
  firn check SCENE.toml [--set key=value ...] [--max-memory SIZE]
  firn render OUT_DIR [--color-by Q] [--frames A:B] [--size WxH] [more: firn render --help]
  firn report OUT_DIR [--times t1,t2,...] [--quiet]
  firn compare RUN_A RUN_B [--out DIR] [--force] [--tolerance name=value ...]
               [--color-by Q] [--size WxH] [more: firn compare --help]
  firn keys [--markdown]
  firn --help | firn COMMAND --help | firn --version

commands:
  run     simulate the scene; write VDB caches, metrics.csv and summary.json
  check   parse and validate the scene, print what it would simulate, run nothing
  render  PNG frames, a contact sheet and a video of a finished run in OUT_DIR/render/
  report  charts of a finished run (failure maps, crack, flow) in OUT_DIR/report/report.html
  compare two runs of one scene side by side (renders, curves, values) in compare.html
  keys    every scene key with its default, as the manual's scene reference lists them

Exit codes: 0 ok, 1 scene or usage error, 2 simulation unstable, 3 I/O or resource error,
4 internal error, 5 compare: a figure moved beyond its tolerance, 130 interrupted.
The manual (docs/, mkdocs build) has the scene reference: docs/reference/scene.md.
)";

const char* kRunHelp = R"(usage: firn run SCENE.toml [options]

Simulates the scene and writes into its output folder (output.directory, default out/<name>):
frames/particles.NNNN.vdb, frames/volume.NNNN.vdb, metrics.csv, summary.json, scene.toml.

options:
  --threads N        worker threads (default: all cores); results are bitwise identical
                     for any N
  --out DIR          output folder, overrides output.directory
  --set key=value    override a scene value, e.g. --set grid.dx=0.025
                     --set simulation.end_time=0.5 --set material.slab.youngs_modulus=2e6
                     --set body.weak.thickness=0.05 (a named body)
                     --set cut.weak.length=0.4 (the [[cut]] of layer "weak")
                     (repeatable; the value is TOML: strings need quotes or are bare words)
  --checkpoint-every N|Mmin
                     write a checkpoint (the whole state, OUT_DIR/checkpoints/) every N frames
                     or every M minutes of wall time (e.g. 20, 5min); 0: never. Default: the
                     scene's output.checkpoint_every_frames / _minutes (every 10 minutes)
  --resume OUT_DIR   continue the run in OUT_DIR from its newest valid checkpoint, with the
                     folder's scene.toml; the finished run is bitwise the run that was not
                     interrupted (no scene file, --out or --set with it)
  --max-memory SIZE  the memory the run may use (e.g. 8G, 512M); default: what the machine
                     has free (its available memory, a cgroup limit, ulimit -v). A scene
                     estimated to need more is refused before anything is written (exit 3)
  --quiet            no progress line on stderr
  -h, --help         this text
)";

const char* kCheckHelp = R"(usage: firn check SCENE.toml [--set key=value ...] [--max-memory SIZE]

Parses and validates the scene without running it and prints each material's parameters with
where each came from (scene file line, --set, the snow parameter table, or a default), the
particles per body, the grid spacing, the time step and the estimated number of steps, and
the memory the run will need against what is available (--max-memory as for firn run). A
scene too large to seed in about a second gets estimated counts only.
Exit code 1 on any scene error.
)";

const char* kReportHelp = R"(usage: firn report OUT_DIR [--times t1,t2,...] [--quiet]

Writes OUT_DIR/report/report.html (self-contained, images embedded) and its PNGs from a folder
written by `firn run`: failure maps of the weak layer (failed/elastic, pressure p, slab speed;
Gaume et al. 2019, Fig. A1), crack tip against time and crack speed against position, maximum
flow speed and kinetic energy against time, the run on the McClung & Gauer (2018) diagram and
its alpha angle, and the summary table. The tables behind the charts are in OUT_DIR/report/data.
Needs /usr/bin/python3 with matplotlib (Debian: python3-matplotlib).

options:
  --times t1,t2,...  simulated times (s) of the failure maps; each map shows the nearest frame
                     (default: 4 frames evenly spaced while the crack runs, else over the run)
  --quiet            no progress lines on stderr
  -h, --help         this text
)";

const char* kKeysHelp = R"(usage: firn keys [--markdown]

Lists every scene key with its default: one line per key (table.key = default). With
--markdown, the tables of the manual's scene reference (docs/reference/scene.md) and of the
metrics.csv columns and summary.json keys (docs/reference/outputs.md), each between its marker
lines as the pages hold them; the tests fail when a page and this output differ.
)";

struct UsageError {
    std::string message;
};

struct Command {
    std::string name, scene; // scene: the scene file, or the output folder for `report`
    firn::RunOptions run;
    firn::ReportOptions report;
    std::vector<std::string> overrides;
    std::string resumeDir; ///< firn run --resume OUT_DIR
    bool help = false;
};

std::string needValue(int& i, int argc, char** argv) {
    if (i + 1 >= argc) throw UsageError{std::string(argv[i]) + " needs a value"};
    return argv[++i];
}

std::vector<double> parseTimes(const std::string& text) {
    std::vector<double> times;
    std::size_t start = 0;
    while (start <= text.size()) {
        const std::size_t comma = std::min(text.find(',', start), text.size());
        const std::string item = text.substr(start, comma - start);
        try {
            std::size_t used = 0;
            const double t = std::stod(item, &used);
            if (used != item.size() || !(t >= 0.0)) throw std::invalid_argument(item);
            times.push_back(t);
        } catch (const std::exception&) {
            throw UsageError{"--times takes times in seconds separated by commas, e.g. "
                             "--times 0.1,0.2; got '" +
                             item + "' in '" + text + "'"};
        }
        start = comma + 1;
    }
    return times;
}

int parseThreads(const std::string& text) {
    try {
        std::size_t used = 0;
        const int n = std::stoi(text, &used);
        if (used == text.size() && n >= 1) return n;
    } catch (const std::exception&) {
    }
    throw UsageError{"--threads must be a positive integer, got '" + text + "'"};
}

/// "20" (frames), "5min" or "5m" (minutes of wall time), "0" (never).
void parseCheckpointEvery(const std::string& text, firn::RunOptions& run) {
    try {
        std::size_t used = 0;
        const double n = std::stod(text, &used);
        const std::string unit = text.substr(used);
        if (n >= 0 && std::isfinite(n) && (unit == "min" || unit == "m")) {
            run.checkpointEveryMinutes = n;
            run.checkpointEveryFrames = 0;
            return;
        }
        if (unit.empty() && n >= 0 && n == std::floor(n) && n < 1e9) {
            run.checkpointEveryFrames = int(n);
            run.checkpointEveryMinutes = 0;
            return;
        }
    } catch (const std::exception&) {
    }
    throw UsageError{"--checkpoint-every takes frames (e.g. 20) or minutes (e.g. 5min), got '" +
                     text + "'"};
}

double parseMaxMemory(const std::string& text) {
    try {
        return firn::parseByteSize(text);
    } catch (const std::invalid_argument& e) {
        throw UsageError{std::string("--max-memory: ") + e.what()};
    }
}

Command parseCommand(int argc, char** argv) {
    Command c;
    c.name = argv[1];
    for (int i = 2; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "-h" || a == "--help")
            c.help = true;
        else if (a == "--set")
            c.overrides.push_back(needValue(i, argc, argv));
        else if (a == "--threads" && c.name == "run")
            c.run.threads = parseThreads(needValue(i, argc, argv));
        else if (a == "--out" && c.name == "run")
            c.run.outDir = needValue(i, argc, argv);
        else if (a == "--quiet" && c.name == "run")
            c.run.quiet = true;
        else if (a == "--checkpoint-every" && c.name == "run")
            parseCheckpointEvery(needValue(i, argc, argv), c.run);
        else if (a == "--resume" && c.name == "run")
            c.resumeDir = needValue(i, argc, argv);
        else if (a == "--max-memory" && (c.name == "run" || c.name == "check"))
            c.run.maxMemoryBytes = parseMaxMemory(needValue(i, argc, argv));
        else if (a == "--times" && c.name == "report")
            c.report.times = parseTimes(needValue(i, argc, argv));
        else if (a == "--quiet" && c.name == "report")
            c.report.quiet = true;
        else if (!a.empty() && a[0] == '-')
            throw UsageError{"unknown option '" + a + "' for firn " + c.name};
        else if (c.scene.empty())
            c.scene = a;
        else if (c.name == "report")
            throw UsageError{"one output folder only, got '" + c.scene + "' and '" + a + "'"};
        else
            throw UsageError{"one scene file only, got '" + c.scene + "' and '" + a + "'"};
    }
    if (!c.resumeDir.empty()) {
        if (!c.scene.empty() || !c.overrides.empty() || !c.run.outDir.empty())
            throw UsageError{"--resume continues a run as it was: no scene file, --set or --out "
                             "with it"};
        return c;
    }
    if (!c.help && c.scene.empty()) {
        throw UsageError{"firn " + c.name +
                         (c.name == "report" ? " needs an output folder" : " needs a scene file")};
    }
    if (c.name == "report" && !c.overrides.empty()) {
        throw UsageError{"--set does not apply to firn report (it reads the run as it was)"};
    }
    return c;
}

int finishRun(const firn::RunResult& r, bool quiet);

int runCommand(const Command& c) {
    if (c.name == "report") {
        firn::ReportOptions options = c.report;
        options.outDir = c.scene;
        std::printf("%s\n", firn::writeReport(options).c_str());
        return 0;
    }
    if (!c.resumeDir.empty()) {
        firn::RunOptions options = c.run;
        options.outDir = c.resumeDir;
        options.resume = true;
        const std::string sceneToml = c.resumeDir + "/scene.toml";
        std::ifstream in(sceneToml, std::ios::binary);
        if (!in)
            throw firn::IoError("cannot resume: " + sceneToml +
                                " not found (is this a folder written by firn run?)");
        std::ostringstream text;
        text << in.rdbuf();
        options.resumeSceneToml = text.str();
        return finishRun(
            firn::runScene(firn::parseScene(options.resumeSceneToml, sceneToml, {}), options),
            c.run.quiet);
    }
    const firn::SceneDesc scene = firn::loadScene(c.scene, c.overrides);
    if (c.name == "check") {
        std::fputs(firn::describeScene(scene, c.run.maxMemoryBytes).c_str(), stdout);
        return 0;
    }
    return finishRun(firn::runScene(scene, c.run), c.run.quiet);
}

int finishRun(const firn::RunResult& r, bool quiet) {
    if (r.status == "unstable") {
        std::fprintf(stderr, "firn: %s\n", r.message.c_str());
        return 2;
    }
    if (r.status == "interrupted") {
        std::fprintf(stderr, "firn: %s; %d frames kept in %s\n", r.message.c_str(), r.frames,
                     r.outDir.c_str());
        return 130;
    }
    if (!quiet)
        std::fprintf(stderr, "firn: %d frames, %lld steps, %zu particles in %.1f s -> %s\n",
                     r.frames, r.steps, r.particles, r.wallSeconds, r.outDir.c_str());
    return 0;
}

// firn keys [--markdown]: the scene keys as the manual documents them (firn/scene_keys.h).
int keysCommand(const std::vector<std::string>& args) {
    bool markdown = false;
    for (const std::string& a : args) {
        if (a == "-h" || a == "--help") {
            std::fputs(kKeysHelp, stdout);
            return 0;
        }
        if (a != "--markdown") throw UsageError{"keys: unknown option '" + a + "'"};
        markdown = true;
    }
    if (markdown) {
        auto print = [](const std::string& table, const std::string& text) {
            std::printf("%s\n%s\n%s\n\n", firn::keyTableBegin(table).c_str(), text.c_str(),
                        firn::kKeyTableEnd);
        };
        for (const std::string& section : firn::sceneKeySections())
            print(section, firn::sceneKeyTable(section));
        for (const char* file : {"metrics.csv", "summary.json"})
            print(file, firn::outputKeyTable(file));
        return 0;
    }
    for (const firn::SceneKeyDoc& doc : firn::sceneKeyDocs()) {
        std::string value = doc.defaultValue; // Markdown: drop the code marks
        value.erase(std::remove(value.begin(), value.end(), '`'), value.end());
        for (const std::string& key : firn::keyNames(doc))
            std::printf("%s.%s = %s\n", doc.section, key.c_str(), value.c_str());
    }
    return 0;
}

} // namespace

int main(int argc, char** argv) {
    if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h")) {
        std::fputs(kUsage, argc < 2 ? stderr : stdout);
        return argc < 2 ? 1 : 0;
    }
    if (!std::strcmp(argv[1], "--version")) {
        std::printf("firn %s\n", FIRN_VERSION);
        return 0;
    }
    // Past a file-size limit (ulimit -f) a write fails with EFBIG and Firn reports it (exit
    // 3); the default action of SIGXFSZ would kill the process mid-file instead.
    std::signal(SIGXFSZ, SIG_IGN);
    try {
        const std::string name = argv[1];
        if (name == "render") {
            firn::cli::RenderCommand c;
            try {
                c = firn::cli::parseRenderCommand({argv + 2, argv + argc});
            } catch (const std::invalid_argument& e) {
                throw UsageError{e.what()};
            }
            if (c.help) {
                std::fputs(firn::cli::kRenderHelp, stdout);
                return 0;
            }
            return firn::cli::runRenderCommand(c);
        }
        if (name == "compare") {
            firn::cli::CompareCommand c;
            try {
                c = firn::cli::parseCompareCommand({argv + 2, argv + argc});
            } catch (const std::invalid_argument& e) {
                throw UsageError{e.what()};
            }
            if (c.help) {
                std::fputs(firn::cli::kCompareHelp, stdout);
                return 0;
            }
            return firn::cli::runCompareCommand(c);
        }
        if (name == "keys") return keysCommand({argv + 2, argv + argc});
        if (name != "run" && name != "check" && name != "report")
            throw UsageError{"unknown command '" + name + "'"};
        const Command c = parseCommand(argc, argv);
        if (c.help) {
            std::fputs(c.name == "run"      ? kRunHelp
                       : c.name == "report" ? kReportHelp
                                            : kCheckHelp,
                       stdout);
            return 0;
        }
        return runCommand(c);
    } catch (const UsageError& e) {
        std::fprintf(stderr, "firn: error: %s\n(see firn --help)\n", e.message.c_str());
        return 1;
    } catch (const firn::SceneError& e) {
        std::fprintf(stderr, "%s\n", e.what());
        return 1;
    } catch (const firn::DifferentScenesError& e) {
        std::fprintf(stderr, "firn compare: %s\n", e.what());
        return 1;
    } catch (const firn::IoError& e) {
        std::fprintf(stderr, "firn: I/O error: %s\n", e.what());
        return 3;
    } catch (const firn::ResourceError& e) {
        std::fprintf(stderr, "firn: not enough memory: %s\n", e.what());
        return 3;
    } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "firn: out of memory: an allocation failed although the estimate "
                             "fitted (another process took memory?); try a larger grid.dx or a "
                             "lower --max-memory\n");
        return 3;
    } catch (const firn::SimulationError& e) {
        std::fprintf(stderr, "firn: simulation failed: %s\n", e.what());
        return 2;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "firn: internal error: %s\n", e.what());
        return 4;
    }
}
