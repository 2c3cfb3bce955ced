#include "report/map_frames.h"

#include <firn/errors.h>
#include <firn/io.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace firn::report {
namespace {

constexpr int kAutomaticMaps = 4;

std::size_t nearestIndex(const std::vector<double>& times, double t) {
    std::size_t best = 0;
    for (std::size_t i = 1; i < times.size(); ++i) {
        if (std::abs(times[i] - t) < std::abs(times[best] - t)) best = i;
    }
    return best;
}

std::vector<std::size_t> requestedIndices(const std::vector<double>& times,
                                          const std::vector<double>& requested) {
    // Half the frame interval of slack at either end: a time that rounds to a frame is fine.
    const double halfFrame = times.size() > 1 ? 0.5 * (times[1] - times[0]) : 0.0;
    std::vector<std::size_t> out;
    for (double t : requested) {
        if (!(t >= times.front() - halfFrame && t <= times.back() + halfFrame)) {
            throw SceneError(SourceLoc{"--times", 0, 0}, "",
                             formatNumber(t) + " s is outside the run's frames (" +
                                 formatNumber(times.front()) + " to " + formatNumber(times.back()) +
                                 " s)");
        }
        out.push_back(nearestIndex(times, t));
    }
    return out;
}

/// [first, last] indices of the crack's run; first == last when there is none to show.
std::pair<std::size_t, std::size_t> crackRun(const std::vector<double>& tip, double dx) {
    std::size_t first = 0;
    while (first < tip.size() && std::isnan(tip[first])) ++first;
    if (first == tip.size()) return {0, 0};
    std::size_t lastFinite = tip.size() - 1;
    while (std::isnan(tip[lastFinite])) --lastFinite;
    std::size_t arrival = first;
    while (arrival < lastFinite && !(std::abs(tip[arrival] - tip[lastFinite]) <= dx)) ++arrival;
    return {first, arrival};
}

std::vector<std::size_t> evenlySpaced(std::size_t first, std::size_t last) {
    std::vector<std::size_t> out;
    for (int k = 0; k < kAutomaticMaps; ++k) {
        out.push_back(first + std::size_t(std::lround(double(k) * double(last - first) /
                                                      double(kAutomaticMaps - 1))));
    }
    return out;
}

} // namespace

std::vector<int> chooseMapFrames(const std::vector<int>& frames, const std::vector<double>& times,
                                 const std::vector<double>& crackTip,
                                 const std::vector<double>& requested, double dx) {
    if (frames.size() != times.size() || frames.size() != crackTip.size()) {
        throw std::invalid_argument("chooseMapFrames: frames, times and crack tips differ in size");
    }
    if (frames.empty()) return {};
    std::vector<std::size_t> indices;
    if (!requested.empty()) {
        indices = requestedIndices(times, requested);
    } else {
        auto [first, last] = crackRun(crackTip, dx);
        if (first == last) first = 0, last = frames.size() - 1;
        indices = evenlySpaced(first, last);
    }
    std::vector<int> out;
    for (std::size_t i : indices) out.push_back(frames[i]);
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
}

} // namespace firn::report
