// Are two runs' caches the same bits? File bytes cannot tell: OpenVDB writes a fresh random
// UUID into every file header. So the particle attributes and the volume grids' voxels are read
// and compared value for value; the first difference ends the search.
#include <firn/compare.h>

#include <firn/errors.h>

#include "report/particle_reader.h"

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>

#include <cstring>
#include <filesystem>
#include <regex>
#include <set>

namespace firn {
namespace {

namespace fs = std::filesystem;

template <typename T> bool sameBits(const std::vector<T>& a, const std::vector<T>& b) {
    return a.size() == b.size() &&
           (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

/// The first attribute that differs between two particle frames, or "".
std::string particleDifference(const ParticleFrame& a, const ParticleFrame& b) {
    if (a.P.size() != b.P.size()) return "particle count";
    if (!sameBits(a.P, b.P)) return "attribute P";
    if (!sameBits(a.v, b.v)) return "attribute v";
    if (!sameBits(a.material, b.material)) return "attribute material";
    if (!sameBits(a.failed, b.failed)) return "attribute failed";
    if (!sameBits(a.eps_v, b.eps_v)) return "attribute eps_v";
    if (!sameBits(a.eta, b.eta)) return "attribute eta";
    if (!sameBits(a.p, b.p)) return "attribute p";
    if (!sameBits(a.q, b.q)) return "attribute q";
    return "";
}

template <typename GridT> bool sameVoxels(const GridT& a, const GridT& b) {
    if (a.transform() != b.transform() || !a.tree().hasSameTopology(b.tree())) return false;
    auto ib = b.cbeginValueOn();
    for (auto ia = a.cbeginValueOn(); ia; ++ia, ++ib) {
        const auto x = *ia, y = *ib;
        if (ia.getCoord() != ib.getCoord() || std::memcmp(&x, &y, sizeof x) != 0) return false;
    }
    return true;
}

openvdb::GridPtrVecPtr readGrids(const std::string& path) {
    try {
        openvdb::io::File file(path);
        file.open();
        openvdb::GridPtrVecPtr grids = file.getGrids();
        file.close();
        return grids;
    } catch (const openvdb::Exception& e) {
        throw IoError("cannot read " + path + ": " + e.what());
    }
}

/// The first grid that differs between two volume files, or "".
std::string volumeDifference(const std::string& pathA, const std::string& pathB) {
    const auto a = readGrids(pathA), b = readGrids(pathB);
    if (a->size() != b->size()) return "number of grids";
    for (const auto& gridA : *a) {
        const auto found = std::find_if(
            b->begin(), b->end(), [&](const auto& g) { return g->getName() == gridA->getName(); });
        if (found == b->end()) return "grid " + gridA->getName() + " in one run only";
        const auto& gridB = *found;
        bool same = gridA->type() == gridB->type();
        if (same && gridA->isType<openvdb::FloatGrid>()) {
            same = sameVoxels(*openvdb::gridPtrCast<openvdb::FloatGrid>(gridA),
                              *openvdb::gridPtrCast<openvdb::FloatGrid>(gridB));
        } else if (same && gridA->isType<openvdb::Vec3fGrid>()) {
            same = sameVoxels(*openvdb::gridPtrCast<openvdb::Vec3fGrid>(gridA),
                              *openvdb::gridPtrCast<openvdb::Vec3fGrid>(gridB));
        } else {
            same = false; // a grid type Firn does not write: not known to be equal
        }
        if (!same) return "grid " + gridA->getName();
    }
    return "";
}

/// Frame numbers of OUT_DIR/frames/<stem>.NNNN.vdb.
std::set<int> listFrames(const std::string& outDir, const std::string& stem) {
    std::set<int> frames;
    std::error_code error;
    const fs::path dir = fs::path(outDir) / "frames";
    if (!fs::is_directory(dir, error)) return frames;
    const std::regex name(stem + R"(\.(\d{4,})\.vdb)");
    for (const auto& entry : fs::directory_iterator(dir, error)) {
        std::smatch m;
        const std::string file = entry.path().filename().string();
        if (std::regex_match(file, m, name)) frames.insert(std::stoi(m[1]));
    }
    return frames;
}

std::string framePath(const std::string& outDir, const std::string& stem, int frame) {
    char name[64];
    std::snprintf(name, sizeof name, "/frames/%s.%04d.vdb", stem.c_str(), frame);
    return outDir + name;
}

} // namespace

CacheComparison compareCaches(const std::string& runA, const std::string& runB) {
    openvdb::initialize();
    CacheComparison c;
    const std::set<int> particlesA = listFrames(runA, "particles"),
                        particlesB = listFrames(runB, "particles");
    const std::set<int> volumesA = listFrames(runA, "volume"),
                        volumesB = listFrames(runB, "volume");
    std::set<int> allA = particlesA, allB = particlesB;
    allA.insert(volumesA.begin(), volumesA.end());
    allB.insert(volumesB.begin(), volumesB.end());
    for (int f : allA) (allB.count(f) ? c.frames : c.onlyInA).push_back(f);
    for (int f : allB)
        if (!allA.count(f)) c.onlyInB.push_back(f);
    if (particlesA != particlesB || volumesA != volumesB) {
        c.firstDifference = "the runs hold different cache frames";
        return c;
    }
    for (int frame : c.frames) {
        if (particlesA.count(frame)) {
            const std::string a = framePath(runA, "particles", frame);
            const std::string what = particleDifference(
                report::readParticleFrame(a).particles,
                report::readParticleFrame(framePath(runB, "particles", frame)).particles);
            if (!what.empty()) {
                c.firstDifference = fs::path(a).filename().string() + ": " + what;
                return c;
            }
        }
        if (volumesA.count(frame)) {
            const std::string a = framePath(runA, "volume", frame);
            const std::string what = volumeDifference(a, framePath(runB, "volume", frame));
            if (!what.empty()) {
                c.firstDifference = fs::path(a).filename().string() + ": " + what;
                return c;
            }
        }
    }
    c.identical = !c.frames.empty();
    return c;
}

} // namespace firn
