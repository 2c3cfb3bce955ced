#include <firn/checkpoint.h>
#include <firn/diagnostics.h>
#include <firn/gis.h>
#include <firn/hazard.h>
#include <firn/io.h>
#include <firn/output_keys.h>
#include <firn/peak_fields.h>
#include <firn/resources.h>
#include <firn/run.h>
#include <firn/settle.h>
#include <firn/slab_fracture.h>
#include <firn/snow_parameters.h>
#include <firn/solver.h>
#include <firn/terrain_export.h>

#include <tbb/global_control.h>
#include <tbb/info.h>

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <sstream>

namespace firn {

namespace {

/// A weak layer fewer than 4 cells thick: there the up-slope crack's speed depends on the layer's
/// `softening` (3 cells: 24 to 69 m/s for alpha 100 to 1000 on bench/slope3d_cut.toml), where at
/// 4 cells (scenes/default.toml) and 6 (the cut at dx 0.05) alpha 50 and 100 give the same crack
/// (docs/slope-scale.md, "The up-slope crack at dx 0.1"), so `firn check` says so and where to read
/// why. Empty for other bodies.
std::string weakLayerResolutionNote(const SceneDesc& scene, const BodyDesc& body) {
    constexpr double kCellsWhereSofteningStopsMattering = 4.0;
    if (!isLayerShape(body.shape) ||
        scene.materials[std::size_t(body.materialIndex)].model != MaterialModel::WeakLayer)
        return "";
    double thickness = body.thickness;
    for (const auto& point : body.thicknessProfile)
        thickness = thickness > 0.0 ? std::min(thickness, point[1]) : point[1];
    const double cells = thickness / scene.grid.dx;
    if (!(cells > 0.0) || cells >= kCellsWhereSofteningStopsMattering) return "";
    std::ostringstream note;
    note << "    note: the weak layer is " << formatNumber(std::round(cells * 10.0) / 10.0)
         << " cells thick; below 4 the crack's speed depends on its `softening` (check against a "
            "finer dx: docs/slope-scale.md, \"The up-slope crack at dx 0.1\")\n";
    return note.str();
}

volatile std::sig_atomic_t gStopSignal = 0;
extern "C" void onStopSignal(int sig) {
    gStopSignal = sig;
}

/// Installs SIGINT/SIGTERM handlers for the duration of a run: the loop then stops after the
/// current step, so no frame file is left half written and the summary says "interrupted".
class SignalGuard {
public:
    SignalGuard() {
        gStopSignal = 0;
        mOldInt = std::signal(SIGINT, onStopSignal);
        mOldTerm = std::signal(SIGTERM, onStopSignal);
        // A run started with SIGINT ignored (`firn run ... &` from a script) keeps ignoring it.
        if (mOldInt == SIG_IGN) std::signal(SIGINT, SIG_IGN);
    }
    ~SignalGuard() {
        std::signal(SIGINT, mOldInt);
        std::signal(SIGTERM, mOldTerm);
    }

private:
    void (*mOldInt)(int);
    void (*mOldTerm)(int);
};

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

std::size_t peakRssBytes() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return std::size_t(usage.ru_maxrss) * 1024;
}

/// One updating line on a terminal, plain lines otherwise, nothing when quiet.
class Progress {
public:
    Progress(bool quiet, int frames)
        : mQuiet(quiet)
        , mTty(isatty(fileno(stderr)))
        , mFrames(frames) {}
    /// Frame k written, `done` frames and `steps` steps of them by this process (a resumed run
    /// started later) in `wall` seconds. With stop_at_rest the run may end before the last frame:
    /// the ETA is then an upper bound, and once the release moves the kinetic energy's share of
    /// its peak shows how near the stop is.
    void frame(int k, int done, double time, std::size_t particles, long long steps, double wall,
               const RestDetector* rest = nullptr, double restFraction = 0.0) {
        if (mQuiet) return;
        const double stepsPerSecond = wall > 0 ? steps / wall : 0.0;
        const double eta = done > 0 ? wall * (mFrames - k) / done : 0.0;
        char restNote[96] = "";
        if (rest && rest->released())
            std::snprintf(restNote, sizeof restNote,
                          "  kinetic energy %.3g %% of peak (stops < %.3g %%)",
                          100.0 * rest->ratio(), 100.0 * restFraction);
        std::fprintf(stderr,
                     "%sframe %d/%d  t=%.4g s  %zu particles  %.1f steps/s  ETA %s%.0f s%s%s",
                     mTty ? "\r\033[K" : "", k, mFrames, time, particles, stepsPerSecond,
                     rest ? "<= " : "", eta, restNote, mTty ? "" : "\n");
        std::fflush(stderr);
    }
    /// The flow stopped (stop_at_rest) at simulated time t.
    void stoppedAtRest(double time, double ratio) {
        if (mQuiet) return;
        std::fprintf(stderr,
                     "%sat rest at t=%.4g s (kinetic energy %.3g %% of its peak): run ends\n",
                     mTty ? "\n" : "", time, 100.0 * ratio);
    }
    void done() {
        if (!mQuiet && mTty) std::fprintf(stderr, "\n");
    }
    /// Before t = 0: the seeded particles, then settling's steps every few seconds of wall
    /// time (a large scene settles for many minutes). Ends its updating line itself.
    BuildObserver observer(double tolerance) {
        BuildObserver o;
        o.interrupted = [] { return gStopSignal != 0; };
        if (mQuiet) return o;
        o.seeded = [](std::size_t particles, double seconds) {
            std::fprintf(stderr, "seeded %zu particles in %.1f s\n", particles, seconds);
        };
        o.settling = [this, tolerance, last = Clock::now(),
                      start = Clock::now()](const SettleProgress& p) mutable {
            if (secondsSince(last) < (mTty ? 1.0 : 30.0)) return;
            last = Clock::now();
            std::fprintf(stderr,
                         "%ssettling: t=%.4g s  %lld steps  %.1f steps/s  %d kinetic-energy "
                         "peaks, the last %.2g of the elastic energy (at rest below %.2g)%s",
                         mTty ? "\r\033[K" : "", p.time, p.steps, p.steps / secondsSince(start),
                         p.kineticResets, p.lastPeakRatio, tolerance, mTty ? "" : "\n");
            std::fflush(stderr);
            mOpenLine = mTty;
        };
        return o;
    }
    /// Ends an updating settling line before other output.
    void endLine() {
        if (mOpenLine) std::fprintf(stderr, "\n");
        mOpenLine = false;
    }

private:
    bool mQuiet, mTty;
    int mFrames;
    bool mOpenLine = false;
};

/// Crack tip and speed from the extent of eta > 0 along x (outputs.md: crack_tip_x, crack_speed).

struct RunState {
    RunState(const SceneDesc& sc, World& w, const std::string& outDir)
        : scene(sc)
        , world(w)
        , framesDir(outDir + "/frames")
        , metrics(outDir + "/metrics.csv", metricColumns())
        , rest(sc.simulation.restEnergyFraction, w.dx) {}
    /// A resumed run: metrics.csv keeps the rows of frames 0..frame.
    RunState(const SceneDesc& sc, World& w, const std::string& outDir, int frame)
        : scene(sc)
        , world(w)
        , framesDir(outDir + "/frames")
        , metrics(outDir + "/metrics.csv", metricColumns(), std::size_t(frame) + 1)
        , rest(sc.simulation.restEnergyFraction, w.dx) {}
    const SceneDesc& scene;
    World& world;
    std::string framesDir;
    MetricsWriter metrics;
    CrackTracker crack;
    CrackArrivalMap arrival; ///< 3D: the crack's arrival over the bed's plan
    SlabFractureTracker slab;
    double lastDt = 0;
    double maxSpeed = 0;
    /// The release's top: the highest point moved snow has had over the frames, m (NaN until
    /// something moves). Snow starts moving where it was, so this is the crown's height.
    double releaseTopX = std::nan(""), releaseTopY = std::nan(""), releaseTopZ = std::nan("");
    /// The centre of mass's (x, z) at each frame: the path the flow took (pathFromTrack).
    PathLine comTrack;
    PathLine givenPath; ///< output.path in the local frame (empty: none given)
    FrameDiagnostics first, last;
    /// Horizontal length of the centre of mass's path over the frames, m.
    double comPathLength = 0;
    RestDetector rest; ///< simulation.stop_at_rest
    std::string stopReason = kStopEndTime;
    PeakFields peaks;       ///< hazard maps on the DEM's grid (empty without a heightfield)
    double peakSeconds = 0; ///< wall time spent sampling them, this process
    Clock::time_point start = Clock::now();
    /// Resident memory before the world was built (libraries, the scene): bytes_per_particle is
    /// charged only what the run adds to it (outputs.md).
    double baselineRss = 0;
    long long stepsAtStart = 0;   ///< a resumed run's step count at its checkpoint
    int checkpointsWritten = 0;   ///< by this process
    double checkpointSeconds = 0; ///< wall time spent writing them
    int framesAtStart = 0;        ///< and the frames written before it
};

std::string cell(double v) {
    return formatNumber(v);
}

/// A simulated position along `axis` in scene coordinates (World::origin; exact when 0).
double inScene(const World& w, int axis, double local) {
    return w.origin[axis] == 0.0 ? local : local + w.origin[axis];
}

/// Where the settled static load exceeds the strength, as keys a script reads without parsing
/// settle_message: the box (scene coordinates) and the count of each material by its name.
void writeSettleOverload(JsonObject& j, const SettleReport& settle, const World& w,
                         const std::vector<MaterialDesc>& materials) {
    // Whole names, as the outputs reference lists them (tests/docs_test.cc reads this file).
    const char* keys[3][2] = {{"settle_overloaded_x_min", "settle_overloaded_x_max"},
                              {"settle_overloaded_y_min", "settle_overloaded_y_max"},
                              {"settle_overloaded_z_min", "settle_overloaded_z_max"}};
    for (int a = 0; a < w.dim; ++a) {
        j.set(keys[a][0], settle.overloadedMin[a]);
        j.set(keys[a][1], settle.overloadedMax[a]);
    }
    std::vector<std::string> names;
    for (const MaterialDesc& m : materials) names.push_back(m.name);
    std::vector<JsonObject> byMaterial;
    for (std::size_t m = 0; m < settle.overloadedByMaterial.size(); ++m) {
        if (settle.overloadedByMaterial[m] == 0) continue;
        JsonObject o;
        o.set("material", materialLabel(names, m));
        o.set("particles", static_cast<long long>(settle.overloadedByMaterial[m]));
        byMaterial.push_back(o);
    }
    j.set("settle_overloaded_by_material", byMaterial);
}

/// Writes frame k (its diagnostics `d` already computed): caches and the metrics row.
void writeFrame(RunState& s, int k, const FrameDiagnostics& d, const StabilityWatch* watch) {
    World& w = s.world;
    const FrameInfo info{k, w.time, s.scene.simulation.frameRate, w.origin};
    const OutputDesc& out = s.scene.output;
    w.grid.rebuild(w.particles, 0);
    std::size_t activeVoxels = 0;
    {
        const VolumeFrame volume = rasterizeVolumes(w.particles, w.grid, w.scratch);
        // The transfers' scratch (padded blocks: up to 20 floats a node of every particle leaf)
        // is rebuilt by the next step; freed here, the caches' grids and arrays do not come on
        // top of it (slope3d, path3d: a frame write was the run's peak).
        w.scratch = TransferScratch{};
        for (float rho : volume.density) activeVoxels += rho > 0.f;
        if (!out.volumes.empty()) writeVolumeCache(s.framesDir, info, volume, out.volumes);
    }
    if (out.particles) writeParticleCache(s.framesDir, info, w.dx, exportParticles(w));
    s.crack.update(d, w.time);
    s.arrival.update(d, w.time);
    s.slab.update(slabSamples(w), w.dx, w.dim, w.time, s.crack);
    const SlabBlocks& blocks = s.slab.blocks();
    s.maxSpeed = std::max(s.maxSpeed, d.maxSpeed);
    if (d.movedTopY > s.releaseTopY || (std::isnan(s.releaseTopY) && !std::isnan(d.movedTopY)))
        s.releaseTopX = d.movedTopX, s.releaseTopY = d.movedTopY, s.releaseTopZ = d.movedTopZ;
    s.comTrack.push_back({d.centreOfMass[0], d.centreOfMass[2]});
    const double nan = std::nan("");
    s.metrics.appendRow({std::to_string(k),
                         cell(w.time),
                         std::to_string(w.steps),
                         cell(s.lastDt),
                         std::to_string(d.particles),
                         std::to_string(activeVoxels),
                         cell(d.mass),
                         cell(inScene(w, 0, d.centreOfMass[0])),
                         cell(inScene(w, 1, d.centreOfMass[1])),
                         cell(inScene(w, 2, d.centreOfMass[2])),
                         cell(d.momentum[0]),
                         cell(d.momentum[1]),
                         cell(d.momentum[2]),
                         cell(d.kineticEnergy),
                         cell(d.maxSpeed),
                         cell(inScene(w, 0, d.frontX)),
                         cell(d.hasWeakLayer ? inScene(w, 0, s.crack.tip()) : nan),
                         cell(d.hasWeakLayer ? s.crack.speed() : nan),
                         cell(d.failedFraction),
                         cell(secondsSince(s.start)),
                         cell(d.elasticEnergy),
                         cell(d.gravitationalEnergy),
                         cell(watch ? watch->drift(d) : 0.0),
                         cell(inScene(w, 0, d.crackMinX)),
                         cell(inScene(w, 0, d.crackMaxX)),
                         std::to_string(asleepCount(w)),
                         std::to_string(s.slab.fractures().size()),
                         cell(s.slab.fracturedMassFraction()),
                         std::to_string(blocks.count),
                         cell(blocks.largestMass),
                         cell(blocks.medianMass),
                         cell(w.outflowMass),
                         cell(d.slabSpeed()),
                         cell(inScene(w, 0, d.collapseMinX)),
                         cell(inScene(w, 0, d.collapseMaxX))});
}

/// The run loop's state beside the world's, for checkpoints (what writeFrame and the summary
/// carry from frame to frame).
std::string saveRunState(const RunState& s, const StabilityWatch& watch) {
    ByteWriter out;
    s.crack.save(out);
    s.arrival.save(out);
    s.slab.save(out);
    watch.save(out);
    for (double v :
         {s.lastDt, s.maxSpeed, s.releaseTopX, s.releaseTopY, s.releaseTopZ, s.comPathLength})
        out.value(v);
    out.array(s.comTrack);
    save(out, s.first);
    save(out, s.last);
    s.peaks.save(out);
    s.rest.save(out);
    return out.bytes();
}

void loadRunState(const std::string& bytes, RunState& s, StabilityWatch& watch) {
    ByteReader in(bytes.data(), bytes.size());
    s.crack.load(in);
    s.arrival.load(in);
    s.slab.load(in);
    watch.load(in);
    for (double* v :
         {&s.lastDt, &s.maxSpeed, &s.releaseTopX, &s.releaseTopY, &s.releaseTopZ, &s.comPathLength})
        in.value(*v);
    in.array(s.comTrack);
    load(in, s.first);
    load(in, s.last);
    s.peaks.load(in);
    s.rest.load(in);
}

/// When checkpoints are written: every N frames, every M minutes of wall time, or both.
class CheckpointClock {
public:
    CheckpointClock(int everyFrames, double everyMinutes)
        : mFrames(everyFrames)
        , mSeconds(everyMinutes * 60.0) {}
    bool due(int frame) const {
        return (mFrames > 0 && frame % mFrames == 0) ||
               (mSeconds > 0 && secondsSince(mLast) >= mSeconds);
    }
    void written() { mLast = Clock::now(); }

private:
    int mFrames;
    double mSeconds;
    Clock::time_point mLast = Clock::now();
};

/// Slab fractures (Gaume et al. 2019, sec. 3, Fig. 3) and the slab's blocks at the end.
void writeSlabSummary(const World& w, const SlabFractureTracker& slab, JsonObject& j) {
    std::vector<JsonObject> fractures;
    for (const SlabFracture& f : slab.fractures()) {
        JsonObject o;
        o.set("x", inScene(w, 0, f.x));
        o.set("y", inScene(w, 1, f.y));
        o.set("z", inScene(w, 2, f.z));
        o.set("time", f.time);
        o.set("start_depth_fraction", f.startDepthFraction);
        o.set("distance_behind_crack_tip", f.distanceBehindCrackTip);
        o.set("start_time", f.startTime);
        o.set("distance_behind_crack_tip_at_start", f.distanceBehindCrackTipAtStart);
        fractures.push_back(o);
    }
    j.set("slab_fracture_count", static_cast<long long>(fractures.size()));
    j.set("first_slab_fracture_time",
          fractures.empty() ? std::nan("") : slab.fractures().front().time);
    j.set("slab_fractures", fractures);
    j.set("final_slab_blocks", static_cast<long long>(slab.blocks().count));
    j.set("max_slab_blocks", static_cast<long long>(slab.maxBlocks()));
    j.set("final_largest_block_mass", slab.blocks().largestMass);
}

/// crack_arrival.csv (3D runs with a weak layer): x, z of each bed cell's centre (m, scene
/// coordinates) and the time its weak layer first cracked (s).
void writeCrackArrival(const RunState& s, const std::string& outDir) {
    const World& w = s.world;
    const std::string path = outDir + "/crack_arrival.csv";
    if (w.dim != 3 || !s.last.hasWeakLayer) {
        // An earlier run's file in the same folder would describe that run; none is fine.
        std::error_code ec;
        std::filesystem::remove(path, ec);
        return;
    }
    std::string text = "x,z,time\n";
    const double width = s.arrival.cellWidth();
    for (const CrackArrivalMap::Cell& c : s.arrival.cells())
        text += cell(inScene(w, 0, (double(c.x) + 0.5) * width)) + "," +
                cell(inScene(w, 2, (double(c.z) + 0.5) * width)) + "," + cell(c.time) + "\n";
    writeFileAtomic(path, text);
}

/// On a DEM: the runout point at the far end, along the avalanche's path, of the footprint
/// where the peak pressure reached output.runout_pressure, and alpha along that path
/// (Lied and Bakkehoi 1980; the paper's Fig. 7) in place of alpha along x. The path is the
/// scene's line (output.path) or the centre of mass's track, extended along its end segments.
void writeRunoutAlongPath(const RunState& s, JsonObject& j) {
    const World& w = s.world;
    const OutputDesc& output = s.scene.output;
    const PathLine path = output.path.empty() ? pathFromTrack(s.comTrack, w.dx) : s.givenPath;
    j.set("runout_pressure_threshold", output.runoutPressure);
    j.set("path_source", output.path.empty() ? "derived" : "scene");
    const RunoutAlongPath runout =
        runoutAlongPath(path, {s.releaseTopX, s.releaseTopY, s.releaseTopZ},
                        s.peaks.footprint(output.runoutPressure));
    if (path.size() < 2 || !runout.found || std::isnan(s.releaseTopY)) {
        j.setNull("runout_length"); // nothing moved, or no cell reached the threshold
        j.setNull("runout_point");
        return;
    }
    j.set("alpha_angle_deg", runout.alphaDeg);
    j.set("runout_length", runout.length);
    j.set("runout_point",
          std::vector<double>{inScene(w, 0, runout.point[0]), inScene(w, 1, runout.point[1]),
                              inScene(w, 2, runout.point[2])});
}

void writeSummary(const RunState& s, const RunResult& r, int threads) {
    const World& w = s.world;
    const std::size_t rss = peakRssBytes();
    const double wall = secondsSince(s.start);
    JsonObject j;
    j.set("scene", s.scene.path);
    j.set("dimension", w.dim);
    j.set("particles", static_cast<long long>(w.particles.size()));
    j.set("steps", w.steps);
    j.set("frames", r.frames);
    j.set("end_time", w.time);
    j.set("wall_seconds", wall);
    j.set("threads", threads);
    j.set("particle_steps_per_second",
          wall > 0 ? double(w.particles.size()) * double(w.steps - s.stepsAtStart) / wall : 0.0);
    j.set("peak_rss_bytes", static_cast<long long>(rss));
    j.set("baseline_rss_bytes", static_cast<long long>(s.baselineRss));
    const double added = std::max(0.0, double(rss) - s.baselineRss);
    j.set("bytes_per_particle", w.particles.size() ? added / double(w.particles.size()) : 0.0);
    j.set("mass_initial", s.first.mass);
    j.set("mass_final", s.last.mass);
    j.set("mass_outflow", w.outflowMass); // mass_initial = mass_final + mass_outflow
    j.set("max_speed", s.maxSpeed);
    j.set("max_crack_speed", s.crack.maxSpeed());
    j.set("mean_crack_speed", s.crack.meanSpeed());
    j.set("crack_propagation_distance", s.crack.distance());
    std::vector<JsonObject> tipSteps;
    for (const auto& [time, x] : s.crack.tipSteps()) {
        JsonObject o;
        o.set("time", time);
        o.set("x", inScene(w, 0, x));
        tipSteps.push_back(o);
    }
    j.set("crack_tip_steps", tipSteps);
    writeSlabSummary(w, s.slab, j);
    // Of the snow that moved (kFlagMoved): a base or a slope that never moved is no deposit.
    j.set("runout_x", inScene(w, 0, s.last.movedFarX));
    j.set("runout_y", inScene(w, 1, s.last.movedFarY));
    j.set("release_top_x", inScene(w, 0, s.releaseTopX));
    j.set("release_top_y", inScene(w, 1, s.releaseTopY));
    j.set("alpha_angle_deg",
          alphaAngleDeg(s.releaseTopX, s.releaseTopY, s.last.movedFarX, s.last.movedFarY));
    // The energy-line angle of the centre of mass (V11): its drop over its horizontal path.
    const double drop = s.first.centreOfMass[1] - s.last.centreOfMass[1];
    j.set("com_path_length", s.comPathLength);
    j.set("com_travel_angle_deg",
          s.comPathLength > 0 ? std::atan2(drop, s.comPathLength) * 180.0 / M_PI : std::nan(""));
    if (!s.peaks.empty()) writeRunoutAlongPath(s, j);
    if (!s.peaks.empty()) {
        s.peaks.write(r.outDir + "/rasters");
        j.set("rasters", r.outDir + "/rasters");
        j.set("raster_samples", s.peaks.samples());
        j.set("raster_wall_seconds", s.peakSeconds);
    }
    const SettleReport& settle = w.settle;
    j.setBool("settle", settle.ran);
    if (settle.ran) {
        j.setBool("settle_converged", settle.converged);
        j.set("settle_time", settle.time);
        j.set("settle_steps", settle.steps);
        j.set("settle_cfl", settlingCfl(s.scene.simulation.settleCfl, s.scene.grid.cfl));
        j.set("settle_wall_seconds", settle.wallSeconds);
        j.set("settle_overloaded_particles", static_cast<long long>(settle.overloaded));
        if (settle.overloaded > 0) writeSettleOverload(j, settle, w, s.scene.materials);
        if (!settle.message.empty()) j.set("settle_message", settle.message);
    }
    j.set("status", r.status);
    if (!r.message.empty()) j.set("message", r.message);
    j.set("stop_reason", s.stopReason);
    if (s.scene.simulation.stopAtRest) j.set("rest_energy_ratio", s.rest.ratio());
    j.set("checkpoints_written", s.checkpointsWritten);
    j.set("checkpoint_wall_seconds", s.checkpointSeconds);
    if (r.resumedFromFrame >= 0) j.set("resumed_from_frame", r.resumedFromFrame);
    writeFileAtomic(r.outDir + "/summary.json", j.str());
    writeCrackArrival(s, r.outDir);
}

/// A rerun into the same folder must not leave frames of an earlier, longer run behind.
void removeOldFrames(const std::string& dir) {
    std::error_code ec;
    for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
        const std::string name = entry.path().filename().string();
        const bool frame = (name.rfind("particles.", 0) == 0 || name.rfind("volume.", 0) == 0) &&
                           entry.path().extension() == ".vdb";
        if (frame && !std::filesystem::remove(entry.path(), ec))
            throw IoError("cannot remove old frame " + entry.path().string() + ": " + ec.message());
    }
}

/// The run's hazard maps on the grid peakFieldGrid gives (none without a heightfield).
PeakFields makePeakFields(const SceneDesc& scene, const World& world) {
    const Georeference grid = peakFieldGrid(scene);
    if (grid.columns == 0) return {};
    for (const Collider& c : world.colliders)
        if (c.heightfield()) return PeakFields(grid, world.origin, *c.heightfield());
    return {};
}

/// Settling went unstable (a time step too large for the scene): no frame to keep, but the
/// summary says what happened, as for an unstable run.
void writeUnstableSettleSummary(const SceneDesc& scene, RunResult& result, const char* why) {
    result.status = "unstable";
    result.message = std::string("unstable while settling before t = 0: ") + why;
    MetricsWriter(result.outDir + "/metrics.csv", metricColumns()); // the header, no rows
    JsonObject j;
    j.set("scene", scene.path);
    j.set("dimension", scene.simulation.dimension);
    j.set("steps", 0);
    j.set("frames", 0);
    j.set("end_time", 0.0);
    j.set("wall_seconds", 0.0);
    j.setBool("settle", true);
    j.setBool("settle_converged", false);
    j.set("status", result.status);
    j.set("message", result.message);
    writeFileAtomic(result.outDir + "/summary.json", j.str());
}

} // namespace

RunResult runScene(const SceneDesc& sceneIn, const RunOptions& options) {
    const int threads = options.threads > 0 ? options.threads : tbb::info::default_concurrency();
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    checkMemory(sceneIn, estimateMemory(sceneIn, options.maxMemoryBytes));
    RunResult result;
    result.outDir = options.outDir.empty() ? sceneIn.output.directory : options.outDir;
    const std::string checkpointDir = result.outDir + "/checkpoints";
    SignalGuard signals; // before setup, so that a signal at any time ends with a summary
    const double baselineRss = currentRssBytes();

    // A path file that holds no line fails now, not after the run.
    const PathLine givenPath = sceneIn.output.path.empty()
                                   ? PathLine{}
                                   : readPathLine(sceneIn.output, localFrameOrigin(sceneIn));
    std::unique_ptr<World> world;
    SceneDesc scene = sceneIn;
    LoadedCheckpoint resumed;
    if (options.resume) {
        world = buildWorld(scene, BuildStage::Bare);
        resumed = loadNewestCheckpoint(checkpointDir, options.resumeSceneToml, *world);
        for (const std::string& w : resumed.warnings)
            std::fprintf(stderr, "firn: warning: %s\n", w.c_str());
        scene.path = resumed.scenePath; // the summary names the scene as the first run did
        result.resumedFromFrame = resumed.frame;
        if (!options.quiet)
            std::fprintf(stderr, "resuming from frame %d (t = %.6g s) of %s\n", resumed.frame,
                         world->time, resumed.file.c_str());
    } else {
        makeDirectories(result.outDir + "/frames");
        removeOldFrames(result.outDir + "/frames");
        removeCheckpoints(checkpointDir);
        writeFileAtomic(result.outDir + "/scene.toml", scene.resolvedToml);
        Progress building(options.quiet, 0);
        BuildObserver observer = building.observer(scene.simulation.settleTolerance);
        // terrain.obj and terrain.vdb before the particles exist: the level set's sampling
        // (about 20 MB for slope2d) is then not held on top of them (it was slope2d's peak).
        observer.collidersBuilt = [&](const World& bare) {
            exportTerrain(scene, bare.colliders, result.outDir);
        };
        try {
            world = buildWorld(scene, BuildStage::Settled, observer);
        } catch (const SimulationError& e) {
            building.endLine();
            writeUnstableSettleSummary(scene, result, e.what());
            return result;
        }
        building.endLine();
        if (world->settle.ran && !options.quiet)
            std::fprintf(
                stderr, "settled under gravity in %.3g s (%lld steps, %.1f s wall)%s%s\n",
                world->settle.time, world->settle.steps, world->settle.wallSeconds,
                world->settle.message.empty() ? "" : ": warning: ", world->settle.message.c_str());
    }
    if (options.resume) exportTerrain(scene, world->colliders, result.outDir);
    std::unique_ptr<RunState> state =
        options.resume ? std::make_unique<RunState>(scene, *world, result.outDir, resumed.frame)
                       : std::make_unique<RunState>(scene, *world, result.outDir);
    RunState& s = *state;
    s.baselineRss = baselineRss;
    s.givenPath = givenPath;
    s.peaks = makePeakFields(scene, *world);
    if (!options.resume) s.peaks.accumulate(world->particles); // the release at t = 0
    const int frames =
        std::max(1, int(std::lround(scene.simulation.endTime * scene.simulation.frameRate)));
    Progress progress(options.quiet, frames);
    CheckpointClock checkpoints(
        options.checkpointEveryFrames >= 0 ? options.checkpointEveryFrames
                                           : scene.output.checkpointEveryFrames,
        options.checkpointEveryMinutes >= 0 ? options.checkpointEveryMinutes
                                            : scene.output.checkpointEveryMinutes);

    if (!options.resume) s.first = s.last = computeDiagnostics(*world);
    StabilityWatch watch(s.first, *world);
    int firstFrame = 1;
    // A full disk or a file-size limit mid-run: the frames written so far are complete (each
    // goes to its name only when whole); the summary says what happened, then main exits 3.
    try {
        if (options.resume) {
            loadRunState(resumed.runState, s, watch);
            firstFrame = resumed.frame + 1;
            s.stepsAtStart = world->steps;
            s.framesAtStart = resumed.frame;
            result.frames = resumed.frame + 1;
        } else {
            writeFrame(s, 0, s.first, nullptr);
            result.frames = 1;
        }
        for (int k = firstFrame; k <= frames && result.status == "ok"; ++k) {
            const double frameEnd = k / scene.simulation.frameRate;
            while (world->time < frameEnd - 1e-12 && !gStopSignal) {
                // The last step of a frame is shortened to land on the frame time exactly.
                s.lastDt = std::min(stableTimeStep(*world), frameEnd - world->time);
                step(*world, s.lastDt);
                if (!s.peaks.empty()) {
                    const Clock::time_point t0 = Clock::now();
                    s.peaks.afterStep(world->particles, world->maxSpeed, s.lastDt);
                    s.peakSeconds += secondsSince(t0);
                }
                if (!std::isfinite(world->maxSpeed)) break;
            }
            removeOutflow(*world); // snow that left the domain (simulation.domain_min/max)
            if (gStopSignal) {
                result.status = "interrupted";
                result.message = std::string("stopped by signal ") + std::to_string(gStopSignal) +
                                 " at t = " + std::to_string(world->time) + " s";
                break;
            }
            const FrameDiagnostics d = computeDiagnostics(*world);
            const std::string why = watch.check(d, *world);
            if (!why.empty()) {
                result.status = "unstable";
                result.message = "unstable: " + why + "; last good frame is " +
                                 std::to_string(result.frames - 1);
                break;
            }
            const double ex = d.centreOfMass[0] - s.last.centreOfMass[0];
            const double ez = d.centreOfMass[2] - s.last.centreOfMass[2];
            s.comPathLength += std::sqrt(ex * ex + ez * ez);
            s.last = d;
            writeFrame(s, k, d, &watch);
            ++result.frames;
            if (s.rest.atRest(d.kineticEnergy, s.comPathLength) && s.scene.simulation.stopAtRest &&
                k < frames) {
                s.stopReason = kStopAtRest;
                progress.stoppedAtRest(world->time, s.rest.ratio());
                break;
            }
            if (k < frames && checkpoints.due(k)) {
                const Clock::time_point t0 = Clock::now();
                writeCheckpoint(checkpointDir, k,
                                options.resume ? options.resumeSceneToml : scene.resolvedToml,
                                scene.path, *world, saveRunState(s, watch));
                checkpoints.written();
                ++s.checkpointsWritten;
                s.checkpointSeconds += secondsSince(t0);
            }
            progress.frame(k, k - s.framesAtStart, world->time, world->particles.size(),
                           world->steps - s.stepsAtStart, secondsSince(s.start),
                           scene.simulation.stopAtRest ? &s.rest : nullptr,
                           scene.simulation.restEnergyFraction);
        }
    } catch (const IoError& e) {
        progress.done();
        result.status = "io_error";
        result.message =
            std::string(e.what()) + "; last complete frame is " + std::to_string(result.frames - 1);
        result.steps = world->steps;
        result.particles = world->particles.size();
        try {
            writeSummary(s, result, threads);
        } catch (const IoError&) {
            // No room for the summary either: the message below is all there is.
        }
        throw IoError(result.message);
    }
    progress.done();
    s.peaks.accumulate(world->particles); // the deposit is the final state
    result.steps = world->steps;
    result.particles = world->particles.size();
    result.wallSeconds = secondsSince(s.start);
    writeSummary(s, result, threads);
    return result;
}

/// One material's parameters as the simulation will use them on a grid of spacing dx, and where
/// each came from.
std::string describeMaterial(const MaterialDesc& material, double dx) {
    std::ostringstream out;
    out << "  material \"" << material.name << "\" (" << toString(material.model) << "):\n";
    for (const MaterialParameter& p : materialParameters(material)) {
        std::ostringstream value;
        value << std::setprecision(4) << p.value << (*p.unit ? " " : "") << p.unit;
        out << "    " << std::left << std::setw(30) << p.key << std::setw(16) << value.str()
            << p.origin << "\n";
    }
    const double alpha = crackBandSoftening(material.softening, material.softeningLength, dx);
    if (material.model == MaterialModel::WeakLayer && alpha != material.softening) {
        std::ostringstream value;
        value << std::setprecision(4) << alpha;
        out << "    " << std::left << std::setw(30) << "softening at this dx" << std::setw(16)
            << value.str() << "crack band: softening x " << kCrackBandCells << " dx / "
            << "softening_length\n";
    }
    return out.str();
}

/// For each weak-layer body of `material` (index m) that is a layer: the energy its collapse will
/// dissipate per unit area against the layer the table's alpha was calibrated on, and the
/// softening that would match it (the crack band's coarse side, which Firn does not apply by
/// itself: it would change what an explicit `softening` means).
std::string describeCollapseEnergy(const SceneDesc& scene, std::size_t m) {
    const MaterialDesc& material = scene.materials[m];
    if (material.model != MaterialModel::WeakLayer || material.softening <= 0.0) return {};
    const SnowParameterTable table = weakLayerTable(material.density);
    const double dx = scene.grid.dx;
    std::ostringstream out;
    out << std::setprecision(3);
    for (const BodyDesc& body : scene.bodies) {
        if (body.materialIndex != int(m) || body.shape != BodyShape::Layer) continue;
        double thin = body.thickness, thick = body.thickness;
        if (!body.thicknessProfile.empty()) {
            thin = thick = body.thicknessProfile.front()[1];
            for (const auto& point : body.thicknessProfile) {
                thin = std::min(thin, point[1]);
                thick = std::max(thick, point[1]);
            }
        }
        auto ratio = [&](double thickness) {
            return collapseEnergyRatio(material.softening, material.softeningLength, thickness, dx,
                                       table.softening.value, table.softeningLength.value);
        };
        std::ostringstream value;
        value << std::fixed << std::setprecision(2) << ratio(thin);
        if (thick != thin) value << "-" << ratio(thick);
        value << " x";
        const std::string name = body.name.empty() ? std::string("layer") : body.name;
        out << "    " << std::left << std::setw(30) << "collapse energy per area" << std::setw(16)
            << value.str() << "body \"" << name << "\" (" << thin;
        if (thick != thin) out << "-" << thick;
        out << " m) against the table's " << table.softeningLength.value << " m layer at softening "
            << table.softening.value << ": a band of " << collapseBandThickness(thin, dx);
        if (thick != thin) out << "-" << collapseBandThickness(thick, dx);
        out << " m (the layer, at most " << kCrackBandCells << " dx)\n";
        // Beyond 5 %: say which softening gives the table's energy per area (constant thickness).
        if (thick == thin && std::abs(ratio(thin) - 1.0) > 0.05)
            out << "    " << std::left << std::setw(30) << "softening for the table's"
                << std::setw(16) << std::llround(material.softening * ratio(thin))
                << "gives body \"" << name
                << "\" the table's collapse energy per area (docs/snow.md, crack band)\n";
    }
    return out.str();
}

/// The DEMs, the local frame and the rasters of a scene on real terrain; empty for the others.
std::string describeTerrain(const SceneDesc& scene) {
    std::ostringstream out;
    out << std::setprecision(10);
    for (std::size_t t = 0; t < scene.terrains.size(); ++t) {
        const TerrainDesc& terrain = scene.terrains[t];
        if (terrain.shape != TerrainShape::Heightfield) continue;
        const Georeference g = readDemGeoreference(terrain.file);
        out << "  terrain " << t + 1 << ": DEM " << terrain.file << ", " << g.columns << " x "
            << g.rows << " cells of " << g.cell << " m from (" << g.west << ", " << g.south
            << "), CRS " << (g.crsWkt.empty() ? "not given" : crsName(g.crsWkt)) << "\n";
    }
    const Vec3d origin = localFrameOrigin(scene);
    if (origin != Vec3d{0.0, 0.0, 0.0})
        out << "  local frame: simulated with its origin at (" << origin[0] << ", " << origin[1]
            << ", " << origin[2] << "); outputs are written in the scene's coordinates\n";
    const Georeference rasters = peakFieldGrid(scene);
    if (rasters.columns > 0)
        out << "  rasters: pft, pfv, ppr, dft on " << rasters.columns << " x " << rasters.rows
            << " cells of " << rasters.cell << " m in " << scene.output.directory << "/rasters\n";
    if (rasters.columns > 0) {
        out << "  runout: the far end of the ppr >= " << formatNumber(scene.output.runoutPressure)
            << " kPa footprint along ";
        if (scene.output.path.empty()) {
            out << "the centre of mass's track (no output.path)\n";
        } else {
            const PathLine line = readPathLine(scene.output, localFrameOrigin(scene));
            out << scene.output.path << " (" << line.size() << " points)\n";
        }
    }
    return out.str();
}

std::string describeScene(const SceneDesc& scene, double maxMemoryBytes) {
    const MemoryEstimate memory = estimateMemory(scene, maxMemoryBytes);
    std::ostringstream out;
    out << "scene " << scene.path << ": \"" << scene.simulation.name << "\", "
        << scene.simulation.dimension << "D, dx = " << scene.grid.dx << " m, "
        << scene.grid.particlesPerCell << " particles per cell, transfer "
        << toString(scene.grid.transfer);
    if (scene.grid.transfer == Transfer::Flip) {
        if (scene.grid.flipRelaxationTime > 0)
            out << ", its noise relaxed over " << scene.grid.flipRelaxationTime << " s";
        else
            out << ", blend " << scene.grid.flipBlend;
    }
    if (scene.grid.transfer == Transfer::Xpic) out << ", order " << scene.grid.xpicOrder;
    out << "\n";
    for (std::size_t m = 0; m < scene.materials.size(); ++m)
        out << describeMaterial(scene.materials[m], scene.grid.dx)
            << describeCollapseEnergy(scene, m);
    out << describeTerrain(scene);
    out << "  memory: about " << formatBytes(memory.bytes) << " for about "
        << std::llround(memory.particles) << " particles; "
        << (std::isinf(memory.availableBytes)
                ? std::string("no limit found")
                : formatBytes(memory.availableBytes) + " available (" + memory.limitedBy + ")")
        << "\n";
    // Seeding counts exactly, at ~1 s per few million particles: beyond that (or beyond the
    // memory) the estimate is what check reports.
    constexpr double kMaxSeededInCheck = 3e6;
    if (memory.particles > kMaxSeededInCheck || memory.bytes > memory.availableBytes) {
        for (std::size_t b = 0; b < scene.bodies.size(); ++b) {
            const BodyDesc& body = scene.bodies[b];
            out << "  body " << b + 1 << (body.name.empty() ? "" : " \"" + body.name + "\"") << " ("
                << body.material << "): about " << std::llround(memory.particlesPerBody[b])
                << " particles (estimated)\n";
        }
        if (memory.bytes > memory.availableBytes) {
            try {
                checkMemory(scene, memory);
            } catch (const ResourceError& e) {
                out << "  warning: `firn run` would refuse this scene: " << e.what() << "\n";
            }
        }
        out << "  output: " << scene.output.directory << "\n";
        return out.str();
    }
    std::unique_ptr<World> world = buildWorld(scene, BuildStage::Seeded);
    for (std::size_t b = 0; b < scene.bodies.size(); ++b) {
        const BodyDesc& body = scene.bodies[b];
        out << "  body " << b + 1 << (body.name.empty() ? "" : " \"" + body.name + "\"") << " ("
            << body.material << "): " << world->particlesPerBody[b] << " particles\n";
        out << weakLayerResolutionNote(scene, body);
    }
    const double dt = stableTimeStep(*world);
    out << "  " << world->particles.size() << " particles in " << world->particles.leafCount()
        << " leaves; P-wave speed " << world->maxWaveSpeed << " m/s; dt <= " << dt << " s\n"
        << "  end time " << scene.simulation.endTime << " s: about "
        << std::llround(scene.simulation.endTime / dt) << " steps (at rest; more as it speeds up), "
        << std::lround(scene.simulation.endTime * scene.simulation.frameRate) + 1 << " frames\n"
        << "  start: "
        << (scene.simulation.settle
                ? "settles under gravity before t = 0 (at most " +
                      formatNumber(scene.simulation.settleMaxTime) + " s of settling)"
            : scene.simulation.gravityRamp > 0
                ? "gravity ramped over " + formatNumber(scene.simulation.gravityRamp) + " s"
                : "as seeded, full gravity at t = 0")
        << "\n"
        << "  end: "
        << (scene.simulation.stopAtRest
                ? "at rest (simulation.stop_at_rest): once the centre of mass has moved " +
                      formatNumber(world->dx) + " m, the first frame with kinetic energy below " +
                      formatNumber(100.0 * scene.simulation.restEnergyFraction) +
                      " % of its peak; else at the end time"
                : "at the end time (simulation.stop_at_rest = false)")
        << "\n";
    for (const CutDesc& cut : scene.cuts)
        out << "  cut in layer \"" << cut.layer << "\": x in [" << formatNumber(cut.fromX) << ", "
            << formatNumber(cut.fromX + cut.length) << "] m, "
            << (cut.saw == Saw::QuasiStatic ? "quasi-static saw (cut before settling)"
                                            : "instant saw (removed at t = 0)")
            << "\n";
    if (world->slipMaterial >= 0) {
        std::string above, weak;
        bool frictionGiven = false;
        for (const BodyDesc& body : scene.bodies) {
            if (body.slidesOn.empty()) continue;
            above += (above.empty() ? "\"" : ", \"") + body.name + "\"";
            weak = body.slidesOn;
            frictionGiven = frictionGiven || body.slipFriction >= 0.0;
        }
        out << "  slip surface on weak layer \"" << weak << "\", bodies above: " << above
            << "; friction " << formatNumber(std::round(world->slipFriction * 1000.0) / 1000.0)
            << (frictionGiven ? " (scene)" : " (default: M_d / sqrt(3) of the layer)") << "\n";
    }
    out << "  output: " << scene.output.directory << "\n";
    return out.str();
}

} // namespace firn
