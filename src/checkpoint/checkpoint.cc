#include <firn/checkpoint.h>
#include <firn/io.h>
#include <firn/serial.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

namespace fs = std::filesystem;

namespace firn {

namespace {

constexpr char kMagic[8] = {'F', 'I', 'R', 'N', 'C', 'K', 'P', 'T'};
constexpr const char* kStem = "checkpoint.";
constexpr const char* kSuffix = ".firn";

std::uint64_t hashOf(const std::string& text) {
    return fnv1a64(text.data(), text.size());
}

void saveWorld(ByteWriter& out, const World& w) {
    out.value(w.dim), out.value(w.dx);
    out.value(w.time), out.value(w.steps), out.value(w.maxSpeed), out.value(w.maxWaveSpeed);
    out.value(w.outflowMass);
    const SettleReport& s = w.settle;
    out.value(std::uint8_t(s.ran)), out.value(std::uint8_t(s.converged));
    out.value(std::uint8_t(s.interrupted));
    out.value(s.time), out.value(s.steps), out.value(s.wallSeconds), out.value(s.kineticResets);
    out.value(s.lastPeakRatio), out.value(std::uint64_t(s.overloaded));
    out.value(s.overloadedMin), out.value(s.overloadedMax);
    std::vector<std::uint64_t> perMaterial(s.overloadedByMaterial.begin(),
                                           s.overloadedByMaterial.end());
    out.array(perMaterial);
    out.string(s.message);
    std::vector<std::uint64_t> perBody(w.particlesPerBody.begin(), w.particlesPerBody.end());
    out.array(perBody);
    const ParticleSet& p = w.particles;
    out.array(p.x), out.array(p.v), out.array(p.C), out.array(p.H), out.array(p.tau);
    out.array(p.mass), out.array(p.volume0), out.array(p.material), out.array(p.plastic);
    out.array(p.leaves), out.array(p.leafStart), out.array(p.leafQuietSteps);
    out.array(p.leafSleep), out.array(p.leafPush), out.array(p.leafQuietVelocity);
}

void loadWorld(ByteReader& in, World& w) {
    const int dim = in.value<int>();
    const float dx = in.value<float>();
    if (dim != w.dim || dx != w.dx) throw ByteReadError("dimension or dx differ from the scene's");
    in.value(w.time), in.value(w.steps), in.value(w.maxSpeed), in.value(w.maxWaveSpeed);
    in.value(w.outflowMass);
    SettleReport& s = w.settle;
    s.ran = in.value<std::uint8_t>() != 0;
    s.converged = in.value<std::uint8_t>() != 0;
    s.interrupted = in.value<std::uint8_t>() != 0;
    in.value(s.time), in.value(s.steps), in.value(s.wallSeconds), in.value(s.kineticResets);
    in.value(s.lastPeakRatio);
    s.overloaded = std::size_t(in.value<std::uint64_t>());
    in.value(s.overloadedMin), in.value(s.overloadedMax);
    std::vector<std::uint64_t> perMaterial;
    in.array(perMaterial);
    s.overloadedByMaterial.assign(perMaterial.begin(), perMaterial.end());
    in.string(s.message);
    std::vector<std::uint64_t> perBody;
    in.array(perBody);
    w.particlesPerBody.assign(perBody.begin(), perBody.end());
    ParticleSet& p = w.particles;
    in.array(p.x), in.array(p.v), in.array(p.C), in.array(p.H), in.array(p.tau);
    in.array(p.mass), in.array(p.volume0), in.array(p.material), in.array(p.plastic);
    in.array(p.leaves), in.array(p.leafStart), in.array(p.leafQuietSteps);
    in.array(p.leafSleep), in.array(p.leafPush), in.array(p.leafQuietVelocity);
    const std::size_t n = p.x.size();
    const bool consistent = p.v.size() == n && p.C.size() == n && p.H.size() == n &&
                            p.tau.size() == n && p.mass.size() == n && p.volume0.size() == n &&
                            p.material.size() == n && p.plastic.size() == n &&
                            p.leafStart.size() == p.leaves.size() + 1 &&
                            (p.leaves.empty() || p.leafStart.back() == n);
    if (!consistent) throw ByteReadError("particle arrays of different lengths");
    for (std::int32_t m : p.material)
        if (m < 0 || std::size_t(m) >= w.materials.size())
            throw ByteReadError("a particle's material is not one of the scene's");
}

/// The frames of dir's checkpoints, newest first.
std::vector<int> checkpointFrames(const std::string& dir) {
    std::vector<int> frames;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir, ec)) {
        const std::string name = e.path().filename().string();
        const std::string stem = kStem, suffix = kSuffix;
        if (name.size() <= stem.size() + suffix.size() || name.rfind(stem, 0) != 0 ||
            name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0)
            continue;
        const std::string digits =
            name.substr(stem.size(), name.size() - stem.size() - suffix.size());
        if (digits.find_first_not_of("0123456789") != std::string::npos) continue;
        frames.push_back(std::stoi(digits));
    }
    std::sort(frames.rbegin(), frames.rend());
    return frames;
}

std::string readAll(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError("cannot read checkpoint " + path);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

} // namespace

std::string checkpointFileName(int frame) {
    char name[32];
    std::snprintf(name, sizeof name, "%s%04d%s", kStem, frame, kSuffix);
    return name;
}

void writeCheckpoint(const std::string& dir, int frame, const std::string& sceneToml,
                     const std::string& scenePath, const World& world,
                     const std::string& runState) {
    // The payload goes to the file as it is produced (its size is filled in at the end): a
    // checkpoint of a large run built in memory held its particles' state twice more, payload
    // and file image, beside the world (dx 0.05's 3D slope: about 450 MB each).
    makeDirectories(dir);
    AtomicFileWriter file(dir + "/" + checkpointFileName(frame));
    ByteWriter header;
    header.value(kMagic);
    header.value(kCheckpointFormat);
    const std::uint64_t sizeAt = header.size();
    header.value(std::uint64_t(0));
    file.write(header.bytes());
    std::uint64_t hash = fnv1a64(nullptr, 0);
    ByteWriter payload([&](const char* data, std::size_t size) {
        hash = fnv1a64(data, size, hash);
        file.write(data, size);
    });
    payload.string(FIRN_VERSION);
    payload.value(hashOf(sceneToml));
    payload.string(scenePath);
    payload.value(frame);
    saveWorld(payload, world);
    payload.string(runState);
    payload.flush();
    ByteWriter trailer, size;
    trailer.value(hash);
    size.value(payload.size());
    file.write(trailer.bytes());
    file.writeAt(sizeAt, size.bytes());
    file.commit();
    const std::vector<int> frames = checkpointFrames(dir);
    for (std::size_t i = 2; i < frames.size(); ++i) {
        std::error_code ec;
        fs::remove(dir + "/" + checkpointFileName(frames[i]), ec);
    }
}

LoadedCheckpoint loadNewestCheckpoint(const std::string& dir, const std::string& sceneToml,
                                      World& world) {
    LoadedCheckpoint loaded;
    for (int frame : checkpointFrames(dir)) {
        const std::string path = dir + "/" + checkpointFileName(frame);
        const std::string bytes = readAll(path);
        ByteReader header(bytes.data(), bytes.size());
        std::string why;
        try {
            char magic[8];
            header.value(magic);
            if (!std::equal(magic, magic + 8, kMagic)) throw ByteReadError("not a Firn checkpoint");
            const auto format = header.value<std::uint32_t>();
            if (format != kCheckpointFormat)
                throw SceneError(SourceLoc{path, 0, 0}, "checkpoint",
                                 "written in checkpoint format " + std::to_string(format) +
                                     ", this Firn reads format " +
                                     std::to_string(kCheckpointFormat));
            const auto length = header.value<std::uint64_t>();
            if (length + sizeof(std::uint64_t) != header.remaining())
                throw ByteReadError("truncated: " + std::to_string(bytes.size()) +
                                    " bytes, the header promises " + std::to_string(length + 28));
            const char* payload = bytes.data() + 20;
            std::uint64_t stored = 0;
            std::memcpy(&stored, payload + length, sizeof stored);
            if (stored != fnv1a64(payload, length)) throw ByteReadError("checksum mismatch");
            ByteReader in(payload, length);
            std::string version, scenePath;
            in.string(version);
            if (version != FIRN_VERSION)
                throw SceneError(SourceLoc{path, 0, 0}, "checkpoint",
                                 "written by Firn " + version + ", this is Firn " + FIRN_VERSION +
                                     "; rerun the scene from the start");
            if (in.value<std::uint64_t>() != hashOf(sceneToml))
                throw SceneError(SourceLoc{path, 0, 0}, "checkpoint",
                                 "belongs to another scene: the output folder's scene.toml has "
                                 "changed since it was written");
            in.string(scenePath);
            loaded.frame = in.value<int>();
            if (loaded.frame != frame) throw ByteReadError("its frame is not its name's");
            loadWorld(in, world);
            in.string(loaded.runState);
            loaded.file = path;
            loaded.scenePath = scenePath;
            return loaded;
        } catch (const ByteReadError& e) {
            why = e.what();
        }
        loaded.warnings.push_back("checkpoint " + path + " is damaged (" + why +
                                  "); using the one before it");
        ParticleSet empty;
        empty.dim = world.dim, empty.dx = world.dx;
        world.particles = std::move(empty);
    }
    throw IoError("no usable checkpoint in " + dir +
                  (loaded.warnings.empty()
                       ? ""
                       : " (" + std::to_string(loaded.warnings.size()) + " damaged)") +
                  "; run the scene again with `firn run`");
}

void removeCheckpoints(const std::string& dir) {
    for (int frame : checkpointFrames(dir)) {
        std::error_code ec;
        if (!fs::remove(dir + "/" + checkpointFileName(frame), ec) && ec)
            throw IoError("cannot remove old checkpoint in " + dir + ": " + ec.message());
    }
}

} // namespace firn
