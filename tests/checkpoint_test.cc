// Checkpoint and resume: in process, a world saved and loaded steps on bitwise as the original;
// end to end with the real binary ([slow]: ~10 runs, too long under the sanitizers), a run killed
// with SIGKILL at random moments and resumed (with another thread count) finishes bitwise as the
// run that was never interrupted; damaged checkpoints are skipped with a warning; checkpoints of
// another scene or another format are refused; a checkpoint streams to its file as a kept image
// would be.
#include "firn_process.h"

#include <firn/checkpoint.h>
#include <firn/serial.h>
#include <firn/solver.h>

#include <catch2/catch.hpp>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <random>
#include <set>

namespace fs = std::filesystem;
using namespace firn;
using namespace firn::test;

namespace {

/// The default scene (a slab on a weak layer on the 2D slope, a snowman standing on it) at dx 0.1
/// for 0.5 s: the snowman's load fails the layer at t = 0 and the crack runs, so the crack and
/// slab trackers carry state across the checkpoints; 25 frames, a few seconds.
const std::vector<std::string> kSceneArgs = {FIRN_SOURCE_DIR "/scenes/default.toml",
                                             "--set",
                                             "grid.dx=0.1",
                                             "--set",
                                             "simulation.end_time=0.5",
                                             "--set",
                                             "output.volumes=[\"density\",\"eta\"]"};

std::vector<std::string> runArgs(const std::string& out, int threads) {
    std::vector<std::string> args = {"run"};
    args.insert(args.end(), kSceneArgs.begin(), kSceneArgs.end());
    args.insert(args.end(), {"--out", out, "--quiet", "--threads", std::to_string(threads),
                             "--checkpoint-every", "2"});
    return args;
}

/// Lines of `csv` with the cells of the named columns left out.
std::string withoutColumns(const std::string& csv, const std::set<std::string>& drop) {
    std::istringstream in(csv);
    std::string line, out;
    std::vector<bool> dropped;
    while (std::getline(in, line)) {
        std::istringstream cells(line);
        std::string cell;
        for (std::size_t c = 0; std::getline(cells, cell, ','); ++c) {
            if (dropped.size() <= c) dropped.push_back(drop.count(cell) > 0);
            if (!dropped[c]) out += cell + ",";
        }
        out += "\n";
    }
    return out;
}

/// The lines of summary.json without the keys in `drop`, and without trailing commas: what
/// may differ between an interrupted and an uninterrupted run (wall times, memory, threads,
/// the checkpoints this process wrote).
std::string withoutKeys(const std::string& json, const std::set<std::string>& drop) {
    std::istringstream in(json);
    std::string line, out;
    while (std::getline(in, line)) {
        const std::size_t q = line.find('"');
        const std::size_t e = q == std::string::npos ? q : line.find('"', q + 1);
        if (e != std::string::npos && drop.count(line.substr(q + 1, e - q - 1))) continue;
        if (!line.empty() && line.back() == ',') line.pop_back(); // the last key has none
        out += line + "\n";
    }
    return out;
}

const std::set<std::string> kWallKeys = {"wall_seconds",        "particle_steps_per_second",
                                         "peak_rss_bytes",      "bytes_per_particle",
                                         "baseline_rss_bytes",  "threads",
                                         "settle_wall_seconds", "resumed_from_frame",
                                         "checkpoints_written", "checkpoint_wall_seconds",
                                         "raster_wall_seconds"};

/// Every file a run leaves, but checkpoints and the captured output.
std::vector<std::string> outputFiles(const std::string& dir) {
    std::vector<std::string> files;
    for (const auto& e : fs::recursive_directory_iterator(dir)) {
        const std::string rel = fs::relative(e.path(), dir).string();
        if (e.is_regular_file() && rel.rfind("checkpoints", 0) != 0) files.push_back(rel);
    }
    std::sort(files.begin(), files.end());
    return files;
}

void checkSameRun(const std::string& a, const std::string& b) {
    const std::vector<std::string> files = outputFiles(a);
    REQUIRE(outputFiles(b) == files);
    for (const std::string& f : files) {
        INFO(f);
        if (f == "metrics.csv")
            CHECK(withoutColumns(slurp(a + "/" + f), {"wall_seconds"}) ==
                  withoutColumns(slurp(b + "/" + f), {"wall_seconds"}));
        else if (f == "summary.json")
            CHECK(withoutKeys(slurp(a + "/" + f), kWallKeys) ==
                  withoutKeys(slurp(b + "/" + f), kWallKeys));
        else
            CHECK((slurp(a + "/" + f) == slurp(b + "/" + f))); // caches bitwise, scene.toml
    }
}

} // namespace

TEST_CASE("a run killed at random moments resumes to the same bytes", "[checkpoint][slow]") {
    TempDir dir("firn-checkpoint");
    const std::string reference = dir.path() + "/reference";
    const auto t0 = std::chrono::steady_clock::now();
    REQUIRE(runFirn(runArgs(reference, 2), dir).code == 0);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const std::string summary = slurp(reference + "/summary.json");
    REQUIRE(summary.find("\"frames\": 26") != std::string::npos);
    // The trackers have state to carry: the crack ran and the slab has blocks.
    REQUIRE(summary.find("\"crack_propagation_distance\": 0,") == std::string::npos);
    // Checkpoints: every 2 frames, the last two kept (frames 22 and 24 of 25).
    CHECK(fs::exists(reference + "/checkpoints/" + firn::checkpointFileName(24)));
    CHECK(fs::exists(reference + "/checkpoints/" + firn::checkpointFileName(22)));
    CHECK_FALSE(fs::exists(reference + "/checkpoints/" + firn::checkpointFileName(20)));

    // SIGKILL (no handler runs, as in an out-of-memory kill or a power cut) at moments drawn
    // over the run after its first checkpoint, then resume with the other thread count.
    std::mt19937 random(Catch::rngSeed());
    std::uniform_real_distribution<double> when(0.25, 0.9);
    for (int trial = 0; trial < 3; ++trial) {
        const std::string out = dir.path() + "/killed" + std::to_string(trial);
        const int threads = 1 + trial % 2;
        const Capture cap = captureFiles(dir.path());
        const pid_t pid = spawnFirn(runArgs(out, threads), cap);
        const double killAfter = when(random) * 0.6 * seconds;
        // Kill only once a checkpoint exists (setup time varies with the machine's load).
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
        while (!fs::exists(out + "/checkpoints/" + firn::checkpointFileName(2)) &&
               std::chrono::steady_clock::now() < deadline)
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
        std::this_thread::sleep_for(std::chrono::duration<double>(killAfter));
        kill(pid, SIGKILL);
        const int killed = waitExit(pid, 30.0);
        INFO("trial " << trial << ": killed " << killAfter
                      << " s after the first checkpoint; "
                         "the whole run takes "
                      << seconds << " s");
        const Outcome resumed =
            runFirn({"run", "--resume", out, "--threads", std::to_string(3 - threads)}, dir);
        INFO(resumed.err);
        // The kill may come after the run ended on a fast machine: then there is nothing to
        // resume but the result must still match.
        if (killed == 1000 + SIGKILL) {
            CHECK(resumed.code == 0);
            CHECK(slurp(out + "/summary.json").find("\"resumed_from_frame\": ") !=
                  std::string::npos);
        }
        checkSameRun(reference, out);
    }
}

TEST_CASE("a damaged checkpoint is skipped with a warning, a foreign one refused",
          "[checkpoint][slow]") {
    // One uninterrupted run serves every section (Catch runs the case once per section).
    static TempDir dir("firn-checkpoint-damaged");
    const std::string reference = dir.path() + "/reference";
    if (!fs::exists(reference + "/summary.json"))
        REQUIRE(runFirn(runArgs(reference, 2), dir).code == 0);
    auto copyRun = [&](const std::string& name) {
        const std::string out = dir.path() + "/" + name;
        fs::copy(reference, out, fs::copy_options::recursive);
        return out;
    };
    const std::string newest = "/checkpoints/" + firn::checkpointFileName(24);

    SECTION("truncated: the one before it is used") {
        const std::string out = copyRun("truncated");
        fs::resize_file(out + newest, fs::file_size(out + newest) / 2);
        const Outcome o = runFirn({"run", "--resume", out, "--quiet"}, dir);
        CHECK(o.code == 0);
        CHECK(o.err.find("firn: warning: checkpoint " + out + newest + " is damaged (truncated") !=
              std::string::npos);
        CHECK(slurp(out + "/summary.json").find("\"resumed_from_frame\": 22") != std::string::npos);
        checkSameRun(reference, out);
    }
    SECTION("one flipped bit: the checksum finds it") {
        const std::string out = copyRun("flipped");
        std::string bytes = slurp(out + newest);
        bytes[bytes.size() / 2] ^= 0x10;
        writeText(out + newest, bytes);
        const Outcome o = runFirn({"run", "--resume", out, "--quiet"}, dir);
        CHECK(o.code == 0);
        CHECK(o.err.find("is damaged (checksum mismatch); using the one before it") !=
              std::string::npos);
        checkSameRun(reference, out);
    }
    SECTION("another scene") {
        const std::string out = copyRun("edited");
        writeText(out + "/scene.toml", slurp(out + "/scene.toml") + "\n# edited\n");
        const Outcome o = runFirn({"run", "--resume", out}, dir);
        CHECK(o.code == 1);
        CHECK(o.err == out + newest +
                           ": error: checkpoint: belongs to another scene: the output folder's "
                           "scene.toml has changed since it was written\n");
    }
    SECTION("another checkpoint format") {
        const std::string out = copyRun("format");
        std::string bytes = slurp(out + newest);
        bytes[8] = char(bytes[8] + 1); // the format number follows the 8-byte magic
        writeText(out + newest, bytes);
        const Outcome o = runFirn({"run", "--resume", out}, dir);
        CHECK(o.code == 1);
        CHECK(o.err.find("error: checkpoint: written in checkpoint format " +
                         std::to_string(kCheckpointFormat + 1) + ", this Firn reads format " +
                         std::to_string(kCheckpointFormat)) != std::string::npos);
    }
    SECTION("no checkpoint at all, or no run") {
        const std::string out = copyRun("none");
        fs::remove_all(out + "/checkpoints");
        Outcome o = runFirn({"run", "--resume", out}, dir);
        CHECK(o.code == 3);
        CHECK(o.err == "firn: I/O error: no usable checkpoint in " + out +
                           "/checkpoints; run the scene again with `firn run`\n");
        o = runFirn({"run", "--resume", dir.path() + "/nothing"}, dir);
        CHECK(o.code == 3);
        CHECK(o.err.find("scene.toml not found") != std::string::npos);
    }
    SECTION("a fresh run into the folder removes the old checkpoints") {
        const std::string out = copyRun("rerun");
        std::vector<std::string> args = runArgs(out, 2);
        args.back() = "0"; // --checkpoint-every 0: none
        REQUIRE(runFirn(args, dir).code == 0);
        CHECK(fs::is_empty(out + "/checkpoints"));
    }
}

TEST_CASE("a world saved and loaded steps on bitwise as the original", "[checkpoint]") {
    // A granular sphere thrown onto a plane beside a box resting there, asleep by the save.
    const SceneDesc scene = sceneFromText(R"([simulation]
name = "roundtrip"
dimension = 2
end_time = 1.0

[grid]
dx = 0.05
particles_per_cell = 4
sleep_steps = 20

[[material]]
name = "sand"
model = "granular"

[[terrain]]
shape = "plane"
point = [0.0, 0.0]
normal = [0.0, 1.0]

[[body]]
material = "sand"
shape = "box"
min = [0.0, 0.0]
max = [1.0, 0.3]

[[body]]
material = "sand"
shape = "sphere"
center = [3.0, 1.0]
radius = 0.2
velocity = [1.0, -1.0]
)");
    TempDir dir("firn-checkpoint-roundtrip");
    auto original = buildWorld(scene);
    advanceTo(*original, 0.8);
    REQUIRE(asleepCount(*original) > 0);
    writeCheckpoint(dir.path(), 7, scene.resolvedToml, scene.path, *original, "run state");

    auto loaded = buildWorld(scene, BuildStage::Bare);
    const LoadedCheckpoint c = loadNewestCheckpoint(dir.path(), scene.resolvedToml, *loaded);
    CHECK(c.frame == 7);
    CHECK(c.runState == "run state");
    CHECK(c.warnings.empty());
    for (World* w : {original.get(), loaded.get()}) advanceTo(*w, 0.9);
    const ParticleSet &a = original->particles, &b = loaded->particles;
    CHECK(loaded->steps == original->steps);
    CHECK(loaded->time == original->time);
    auto same = [](const auto& x, const auto& y) {
        return x.size() == y.size() &&
               std::memcmp(x.data(), y.data(), x.size() * sizeof(x[0])) == 0;
    };
    CHECK(same(a.x, b.x));
    CHECK(same(a.v, b.v));
    CHECK(same(a.C, b.C));
    CHECK(same(a.H, b.H));
    CHECK(same(a.plastic, b.plastic));
    CHECK(same(a.leafSleep, b.leafSleep));

    // Another scene's text: refused; a checkpoint cut short: skipped, and none is left.
    auto other = buildWorld(scene, BuildStage::Bare);
    CHECK_THROWS_AS(loadNewestCheckpoint(dir.path(), scene.resolvedToml + "#", *other), SceneError);
    const std::string file = dir.path() + "/" + checkpointFileName(7);
    fs::resize_file(file, fs::file_size(file) - 9);
    CHECK_THROWS_AS(loadNewestCheckpoint(dir.path(), scene.resolvedToml, *other), IoError);
}

TEST_CASE("a streaming ByteWriter hands over the bytes a keeping one keeps", "[checkpoint]") {
    // Small values buffered into pieces, an array larger than a piece handed over from its own
    // memory, and the tail only on flush(): the concatenation must be the kept bytes, in order.
    std::vector<float> large(300000); // 1.2 MB, above the 1 MiB piece
    for (std::size_t i = 0; i < large.size(); ++i) large[i] = float(i) * 0.5f;
    const std::vector<std::int32_t> small = {1, -2, 3};
    std::string streamed;
    std::vector<std::size_t> pieces;
    ByteWriter kept;
    ByteWriter streaming([&](const char* data, std::size_t size) {
        streamed.append(data, size);
        pieces.push_back(size);
    });
    for (ByteWriter* w : {&kept, &streaming}) {
        w->value(std::uint32_t(7));
        w->string("scene.toml");
        w->array(small);
        w->array(large);
        for (int k = 0; k < 70000; ++k) w->value(double(k)); // 560 kB more: one piece fills
        w->string("tail");
    }
    CHECK(streaming.bytes().size() < (std::size_t(1) << 20)); // never more than a piece kept
    const std::size_t before = streamed.size();
    streaming.flush();
    CHECK(streamed.size() > before); // the tail came only with flush()
    CHECK(streaming.bytes().empty());
    CHECK(streamed == kept.bytes());
    CHECK(streaming.size() == kept.bytes().size());
    CHECK(std::count(pieces.begin(), pieces.end(), large.size() * sizeof(float)) == 1);
}
