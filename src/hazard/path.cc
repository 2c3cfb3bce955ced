#include <firn/hazard.h>

#include <cmath>
#include <limits>

namespace firn {

namespace {

double distance(const std::array<double, 2>& a, const std::array<double, 2>& b) {
    return std::hypot(b[0] - a[0], b[1] - a[1]);
}

} // namespace

double distanceAlongPath(const PathLine& path, double x, double z) {
    PathLine points; // distinct consecutive points
    for (const auto& p : path)
        if (points.empty() || distance(points.back(), p) > 0.0) points.push_back(p);
    if (points.empty()) return 0.0;
    if (points.size() == 1) return std::hypot(x - points[0][0], z - points[0][1]);
    double best = std::numeric_limits<double>::infinity(), along = 0.0, start = 0.0;
    const std::size_t last = points.size() - 2;
    for (std::size_t k = 0; k <= last; ++k) {
        const auto& a = points[k];
        const auto& b = points[k + 1];
        const double len = distance(a, b);
        const double ux = (b[0] - a[0]) / len, uz = (b[1] - a[1]) / len;
        double t = (x - a[0]) * ux + (z - a[1]) * uz; // along this segment, from a
        // The first segment extends backwards, the last forwards; the others are clamped.
        if (k > 0) t = std::max(t, 0.0);
        if (k < last) t = std::min(t, len);
        const double gap = std::hypot(x - (a[0] + t * ux), z - (a[1] + t * uz));
        if (gap < best) best = gap, along = start + t;
        start += len;
    }
    return along;
}

RunoutAlongPath runoutAlongPath(const PathLine& path, const std::array<double, 3>& top,
                                const std::vector<std::array<double, 3>>& footprint) {
    RunoutAlongPath out;
    if (footprint.empty()) return out;
    double farthest = -std::numeric_limits<double>::infinity();
    for (const auto& p : footprint) {
        const double s = distanceAlongPath(path, p[0], p[2]);
        if (s > farthest) farthest = s, out.point = p;
    }
    out.found = true;
    out.length = farthest - distanceAlongPath(path, top[0], top[2]);
    out.alphaDeg = std::atan2(top[1] - out.point[1], out.length) * 180.0 / M_PI;
    return out;
}

PathLine pathFromTrack(const PathLine& track, double minStep) {
    PathLine path;
    for (const auto& p : track)
        if (path.empty() || distance(path.back(), p) >= minStep) path.push_back(p);
    return path;
}

} // namespace firn
