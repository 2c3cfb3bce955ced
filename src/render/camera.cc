// Review cameras: rays per pixel, projection, and the automatic framing of the avalanche.
#include <firn/render.h>

#include <algorithm>
#include <cmath>

namespace firn {
namespace {

constexpr double kPi = 3.14159265358979323846;

Vec3d sub(const Vec3d& a, const Vec3d& b) {
    return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
double dot(const Vec3d& a, const Vec3d& b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
Vec3d cross(const Vec3d& a, const Vec3d& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec3d normalized(const Vec3d& a) {
    const double n = std::sqrt(dot(a, a));
    return n > 0 ? Vec3d{a[0] / n, a[1] / n, a[2] / n} : Vec3d{0, 0, -1};
}

// forward, right, up of a camera; a view straight along `up` falls back to +z as the up hint.
void basis(const Camera& c, Vec3d& f, Vec3d& r, Vec3d& u) {
    f = normalized(sub(c.lookAt, c.position));
    Vec3d hint = c.up;
    if (std::abs(dot(f, normalized(hint))) > 0.999) hint = {0, 0, 1};
    r = normalized(cross(f, hint));
    u = cross(r, f);
}

// Half extents of the image plane at unit distance (perspective) or in metres (orthographic).
void halfExtents(const Camera& c, double& hx, double& hy) {
    hy = c.orthographic ? 0.5 * c.orthoHeight : std::tan(0.5 * c.fovDeg * kPi / 180.0);
    hx = hy * c.width / std::max(1, c.height);
}

bool boxInView(const Camera& c, const Box3& box, double marginPx) {
    for (int corner = 0; corner < 8; ++corner) {
        const Vec3d p = {(corner & 1) ? box.max[0] : box.min[0],
                         (corner & 2) ? box.max[1] : box.min[1],
                         (corner & 4) ? box.max[2] : box.min[2]};
        double px, py;
        if (!c.project(p, px, py)) return false;
        if (px < marginPx || py < marginPx || px > c.width - marginPx || py > c.height - marginPx)
            return false;
    }
    return true;
}

} // namespace

void Camera::ray(double px, double py, Vec3d& origin, Vec3d& direction) const {
    Vec3d f, r, u;
    basis(*this, f, r, u);
    double hx, hy;
    halfExtents(*this, hx, hy);
    const double sx = (2.0 * px / width - 1.0) * hx, sy = (1.0 - 2.0 * py / height) * hy;
    if (orthographic) {
        for (int k = 0; k < 3; ++k) origin[k] = position[k] + sx * r[k] + sy * u[k];
        direction = f;
    } else {
        origin = position;
        direction = normalized({f[0] + sx * r[0] + sy * u[0], f[1] + sx * r[1] + sy * u[1],
                                f[2] + sx * r[2] + sy * u[2]});
    }
}

bool Camera::project(const Vec3d& point, double& px, double& py) const {
    Vec3d f, r, u;
    basis(*this, f, r, u);
    double hx, hy;
    halfExtents(*this, hx, hy);
    const Vec3d d = sub(point, position);
    const double depth = dot(d, f);
    const double scale = orthographic ? 1.0 : depth;
    if (!orthographic && depth <= 1e-9) return false;
    px = 0.5 * width * (1.0 + dot(d, r) / (scale * hx));
    py = 0.5 * height * (1.0 - dot(d, u) / (scale * hy));
    return true;
}

Camera frameBox(const Box3& box, int dimension, int width, int height, double fovDeg) {
    Camera c;
    c.width = width;
    c.height = height;
    c.fovDeg = fovDeg;
    const Vec3d centre = {0.5 * (box.min[0] + box.max[0]), 0.5 * (box.min[1] + box.max[1]),
                          0.5 * (box.min[2] + box.max[2])};
    const Vec3d size = sub(box.max, box.min);
    const double radius = 0.5 * std::sqrt(dot(size, size)) + 1e-6;
    const double margin = 0.06 * std::min(width, height);
    c.lookAt = centre;
    if (dimension == 2) {
        // Side view of the x-y plane: the slope profile as the paper's 2D figures show it.
        c.orthographic = true;
        c.position = {centre[0], centre[1], centre[2] + 4.0 * radius};
        const double aspect = double(width) / height;
        c.orthoHeight = std::max(size[1], size[0] / aspect) / (1.0 - 2.0 * margin / height);
        return c;
    }
    // From the side, a little down-slope (flow runs towards +x), 30 degrees above the horizon.
    const double azimuth = 35.0 * kPi / 180.0, elevation = 30.0 * kPi / 180.0;
    const Vec3d away = {std::sin(azimuth) * std::cos(elevation), std::sin(elevation),
                        std::cos(azimuth) * std::cos(elevation)};
    // The bounding sphere fits at `far`; bisect for the closest distance that keeps every corner
    // of the box inside the margin.
    const double halfFov = 0.5 * fovDeg * kPi / 180.0;
    const double halfFovX = std::atan(std::tan(halfFov) * width / height);
    double lo = 0.0, hi = radius / std::sin(std::min(halfFov, halfFovX)) * 1.5;
    auto place = [&](double distance) {
        c.position = {centre[0] + distance * away[0], centre[1] + distance * away[1],
                      centre[2] + distance * away[2]};
    };
    for (int i = 0; i < 40; ++i) {
        const double mid = 0.5 * (lo + hi);
        place(mid);
        (boxInView(c, box, margin) ? hi : lo) = mid;
    }
    place(hi);
    return c;
}

} // namespace firn
