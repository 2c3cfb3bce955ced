#include <firn/resources.h>
#include <firn/solver.h>

#include <sys/resource.h>
#include <unistd.h>

#include <cctype>
#include <cmath>
#include <fstream>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>

namespace firn {

namespace {

constexpr double kUnlimited = std::numeric_limits<double>::infinity();

/// MemAvailable of /proc/meminfo: what can be allocated without swapping, bytes.
double memAvailable() {
    std::ifstream in("/proc/meminfo");
    std::string key;
    double kb = 0;
    std::string unit;
    while (in >> key >> kb >> unit)
        if (key == "MemAvailable:") return kb * 1024.0;
    return kUnlimited;
}

/// A cgroup v2 limit on this process (containers, batch queues): memory.max - memory.current.
double cgroupAvailable() {
    std::ifstream maxFile("/sys/fs/cgroup/memory.max"),
        currentFile("/sys/fs/cgroup/memory.current");
    std::string max;
    double current = 0;
    if (!(maxFile >> max) || max == "max" || !(currentFile >> current)) return kUnlimited;
    try {
        return std::max(0.0, std::stod(max) - current);
    } catch (const std::exception&) {
        return kUnlimited;
    }
}

/// Room left under an rlimit, given what the process already uses of it.
double rlimitAvailable(int resource, double used) {
    rlimit limit{};
    if (getrlimit(resource, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return kUnlimited;
    return std::max(0.0, double(limit.rlim_cur) - used);
}

/// Virtual size of this process (what RLIMIT_AS counts), bytes.
double virtualSize() {
    std::ifstream in("/proc/self/statm");
    double pages = 0;
    in >> pages;
    return pages * double(sysconf(_SC_PAGESIZE));
}

} // namespace

double currentRssBytes() {
    std::ifstream statm("/proc/self/statm");
    long pages = 0, resident = 0;
    if (!(statm >> pages >> resident)) return 0.0;
    return double(resident) * double(sysconf(_SC_PAGESIZE));
}

std::string formatBytes(double bytes) {
    std::ostringstream out;
    out.precision(bytes >= 1e10 ? 0 : 1);
    out << std::fixed;
    if (bytes >= 1e9)
        out << bytes / 1e9 << " GB";
    else
        out << bytes / 1e6 << " MB";
    return out.str();
}

double parseByteSize(const std::string& text) {
    std::size_t used = 0;
    double value = 0;
    try {
        value = std::stod(text, &used);
    } catch (const std::exception&) {
        throw std::invalid_argument("not a size: '" + text + "' (e.g. 4G, 512M)");
    }
    std::string unit = text.substr(used);
    for (char& c : unit) c = char(std::toupper(static_cast<unsigned char>(c)));
    if (!unit.empty() && unit.back() == 'B') unit.pop_back();
    const double scale = unit.empty()  ? 1.0
                         : unit == "K" ? 1e3
                         : unit == "M" ? 1e6
                         : unit == "G" ? 1e9
                         : unit == "T" ? 1e12
                                       : 0.0;
    if (scale == 0.0 || !(value > 0) || !std::isfinite(value))
        throw std::invalid_argument("not a size: '" + text + "' (e.g. 4G, 512M)");
    return value * scale;
}

MemoryEstimate estimateMemory(const SceneDesc& scene, double maxMemoryBytes) {
    MemoryEstimate e;
    e.particlesPerBody = estimateParticlesPerBody(scene);
    e.particles = std::accumulate(e.particlesPerBody.begin(), e.particlesPerBody.end(), 0.0);
    e.bytes = kBaseBytes + kBytesPerParticle * e.particles;
    e.availableBytes = kUnlimited;
    if (maxMemoryBytes > 0) { // the user's budget replaces what the machine reports
        e.availableBytes = maxMemoryBytes, e.limitedBy = "--max-memory";
        return e;
    }
    auto consider = [&](double bytes, const char* what) {
        if (bytes < e.availableBytes) e.availableBytes = bytes, e.limitedBy = what;
    };
    consider(memAvailable(), "available memory (MemAvailable)");
    consider(cgroupAvailable(), "the cgroup's memory.max");
    consider(rlimitAvailable(RLIMIT_AS, virtualSize()), "ulimit -v");
    consider(rlimitAvailable(RLIMIT_DATA, 0.0), "ulimit -d");
    return e;
}

void checkMemory(const SceneDesc& scene, const MemoryEstimate& e) {
    if (e.bytes <= e.availableBytes) return;
    // Memory grows with particles, dx^-dim: the spacing that would fit.
    const double fitParticles = std::max(0.0, (e.availableBytes - kBaseBytes) / kBytesPerParticle);
    const int dim = scene.simulation.dimension;
    std::ostringstream why;
    why << "the scene needs about " << formatBytes(e.bytes) << " (" << std::llround(e.particles)
        << " particles at dx = " << scene.grid.dx << " m, " << kBytesPerParticle << " bytes each + "
        << formatBytes(kBaseBytes) << "), more than the " << formatBytes(e.availableBytes) << " of "
        << e.limitedBy << ".";
    if (fitParticles > 0) {
        const double dxFit = scene.grid.dx * std::pow(e.particles / fitParticles, 1.0 / dim);
        why << " A grid.dx of " << std::ceil(dxFit * 1e4) / 1e4
            << " m or more would fit (or fewer particles_per_cell, smaller bodies, "
               "--max-memory if the limit is wrong).";
    }
    throw ResourceError(why.str());
}

} // namespace firn
