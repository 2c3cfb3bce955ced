#include <firn/collider.h>
#include <firn/gis.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace firn {

namespace {

// Each of these is one out-of-line function, so that every caller gets the same roundings: the
// compiler contracts multiplies and adds into FMAs by context, and inlined beside another use
// of hx * hx (the normal beside the distance) it contracted them differently.

/// Height above the ground times the cosine of the local slope: the distance to the tangent
/// plane, exact on planar patches and first order elsewhere.
[[gnu::noinline]] float distanceAbove(float y, float height, float hx, float hz) {
    return (y - height) / std::sqrt(1.f + hx * hx + hz * hz);
}

/// The outward unit normal of a ground with slope (dh/dx, dh/dz).
[[gnu::noinline]] Vec3f normalOfSlope(float hx, float hz) {
    return Vec3f(-hx, 1.f, -hz).normalized();
}

} // namespace

Collider Collider::fromDesc(const TerrainDesc& desc, int dim) {
    Collider c;
    c.mShape = desc.shape;
    c.mBoundary = desc.boundary;
    c.mFriction = static_cast<float>(desc.friction);
    c.mDrag.law = desc.boundary;
    c.mDrag.xi = static_cast<float>(desc.turbulence);
    c.mDrag.mu = static_cast<float>(desc.friction);
    c.mDrag.tau0 = static_cast<float>(desc.samosatTau0);
    c.mDrag.rs0 = static_cast<float>(desc.samosatRs0);
    c.mDrag.kappa = static_cast<float>(desc.samosatKappa);
    c.mDrag.roughness = static_cast<float>(desc.samosatR);
    c.mDrag.b = static_cast<float>(desc.samosatB);
    c.mDim = dim;
    c.mPoint = Vec3f(float(desc.point[0]), float(desc.point[1]), float(desc.point[2]));
    c.mNormal = Vec3f(float(desc.normal[0]), float(desc.normal[1]), float(desc.normal[2]));
    if (dim == 2) c.mPoint[2] = 0.f, c.mNormal[2] = 0.f;
    c.mNormal.normalize();
    for (const auto& p : desc.points) c.mProfile.push_back({float(p[0]), float(p[1])});
    for (std::size_t k = 0; k + 1 < c.mProfile.size(); ++k) {
        const float slope =
            (c.mProfile[k + 1][1] - c.mProfile[k][1]) / (c.mProfile[k + 1][0] - c.mProfile[k][0]);
        c.mProfileSecant = std::max(c.mProfileSecant, std::sqrt(1.f + slope * slope));
    }
    if (desc.shape == TerrainShape::Heightfield)
        c.mHeightfield = std::make_shared<const Heightfield>(
            readDem(desc.file, desc.noData)
                .heights.shiftedBy(desc.fileOrigin[0], desc.fileOrigin[2]));
    return c;
}

bool Collider::covers(double xCoord, double zCoord) const {
    if (!mHeightfield) return true;
    const Heightfield& h = *mHeightfield;
    const double half = 0.5 * h.cellSize();
    return xCoord >= h.x0() - half && xCoord <= h.x0() + (h.columns() - 0.5) * h.cellSize() &&
           zCoord >= h.z0() - half && zCoord <= h.z0() + (h.rows() - 0.5) * h.cellSize();
}

std::size_t Collider::profileSegmentAt(float xCoord) const {
    // The first segment whose end is not left of x (x increases strictly along a profile, as
    // the scene reader requires); the ends extend.
    const auto first = mProfile.begin() + 1, last = mProfile.end() - 1;
    const auto it = std::lower_bound(
        first, last, xCoord, [](const std::array<float, 2>& p, float x) { return p[0] < x; });
    return std::size_t(it - first);
}

// The polyline is extended past its ends along its first and last segments, so that the
// ground never ends under a scene. Every grid node next to the ground asks this at every step,
// so the search starts at the segment under px and walks outwards until a segment's x-range
// lies farther from px than the nearest point found: it then returns what a scan of every
// segment returns, bit for bit (the same arithmetic per segment, ties to the lower index).
void Collider::nearestOnProfile(float px, float py, float& cx, float& cy, float& sign) const {
    const std::size_t ns = mProfile.size() - 1;
    float best = std::numeric_limits<float>::max();
    std::size_t bestSegment = ns;
    const auto visit = [&](std::size_t s) {
        const float ax = mProfile[s][0], ay = mProfile[s][1];
        const float ex = mProfile[s + 1][0] - ax, ey = mProfile[s + 1][1] - ay;
        float t = ((px - ax) * ex + (py - ay) * ey) / (ex * ex + ey * ey);
        if (s > 0) t = std::max(t, 0.f);
        if (s + 1 < ns) t = std::min(t, 1.f);
        const float qx = ax + t * ex, qy = ay + t * ey;
        const float d2 = (px - qx) * (px - qx) + (py - qy) * (py - qy);
        if (d2 < best || (d2 == best && s < bestSegment))
            best = d2, bestSegment = s, cx = qx, cy = qy;
    };
    // A segment whose x-range lies a gap g from px is at least g away. The slack covers the
    // rounding of a segment's computed point (a few ulps of x), the factor that of the distances.
    const auto farther = [&](std::size_t s, float gap) {
        const float slack = 4e-6f * (std::abs(mProfile[s][0]) + std::abs(mProfile[s + 1][0]) + 1.f);
        return gap > slack && (gap - slack) * (gap - slack) > 1.001f * best;
    };
    const std::size_t start = std::min(profileSegmentAt(px), ns - 1);
    visit(start);
    for (std::size_t s = start; s-- > 0;) {
        if (farther(s, px - mProfile[s + 1][0])) break;
        visit(s);
    }
    for (std::size_t s = start + 1; s < ns; ++s) {
        if (farther(s, mProfile[s][0] - px)) break;
        visit(s);
    }
    sign = py >= heightAt(px, 0.f) ? 1.f : -1.f;
}

float Collider::heightAt(float xCoord, float zCoord) const {
    if (mHeightfield) return mHeightfield->heightAt(xCoord, zCoord);
    if (mShape == TerrainShape::Plane) {
        // n . (x - p) = 0 solved for y; a vertical plane has no height: report -inf.
        if (std::abs(mNormal[1]) < 1e-6f) return -std::numeric_limits<float>::infinity();
        const float dz = mDim == 3 ? mNormal[2] * (zCoord - mPoint[2]) : 0.f;
        return mPoint[1] - (mNormal[0] * (xCoord - mPoint[0]) + dz) / mNormal[1];
    }
    const std::size_t s = profileSegmentAt(xCoord);
    const auto& a = mProfile[s];
    const auto& b = mProfile[s + 1];
    return a[1] + (b[1] - a[1]) * (xCoord - a[0]) / (b[0] - a[0]);
}

bool Collider::clearOf(const Vec3f& x, float reach) const {
    // A plane's or a heightfield's distance is as cheap as a bound: the caller asks it once.
    if (mShape != TerrainShape::Profile) return false;
    // A profile is the graph of a function whose slope is at most sqrt(secant^2 - 1): a point
    // h above it lies at least h / secant from it. Twice the reach, and a margin for the float
    // rounding of either computation (a few ulps of the coordinates), keep the answer on the
    // side of the full search's.
    const float height = x[1] - heightAt(x[0], 0.f);
    const float margin = 1e-5f * (1.f + std::abs(x[0]) + std::abs(x[1]));
    return height > mProfileSecant * (2.f * reach + margin);
}

float Collider::signedDistance(const Vec3f& x) const {
    if (mShape == TerrainShape::Plane) return mNormal.dot(x - mPoint);
    if (mHeightfield) {
        Slope slope;
        return signedDistance(x, slope);
    }
    float cx = 0.f, cy = 0.f, sign = 1.f;
    nearestOnProfile(x[0], x[1], cx, cy, sign);
    return sign * std::sqrt((x[0] - cx) * (x[0] - cx) + (x[1] - cy) * (x[1] - cy));
}

Vec3f Collider::normal(const Vec3f& x) const {
    if (mShape == TerrainShape::Plane) return mNormal;
    if (mHeightfield) {
        float hx = 0.f, hz = 0.f;
        mHeightfield->gradientAt(x[0], x[2], hx, hz);
        return normalOfSlope(hx, hz);
    }
    float cx = 0.f, cy = 0.f, sign = 1.f;
    nearestOnProfile(x[0], x[1], cx, cy, sign);
    Vec3f n(sign * (x[0] - cx), sign * (x[1] - cy), 0.f);
    const float len = n.norm();
    if (len > 1e-6f) return n / len;
    // On the surface: the normal of the local segment, pointing up.
    const std::size_t s = profileSegmentAt(x[0]);
    Vec3f seg(mProfile[s + 1][0] - mProfile[s][0], mProfile[s + 1][1] - mProfile[s][1], 0.f);
    return Vec3f(-seg[1], seg[0], 0.f).normalized();
}

float Collider::signedDistance(const Vec3f& x, Slope& slope) const {
    if (!mHeightfield) return signedDistance(x);
    float h = 0.f;
    mHeightfield->sampleAt(x[0], x[2], h, slope.dhdx, slope.dhdz);
    return distanceAbove(x[1], h, slope.dhdx, slope.dhdz);
}

Vec3f Collider::normal(const Vec3f& x, const Slope& slope) const {
    return mHeightfield ? normalOfSlope(slope.dhdx, slope.dhdz) : normal(x);
}

bool Collider::carriesWeight(const Vec3f& gravity) const {
    if (mShape != TerrainShape::Plane) return true; // a height function: ground
    const float g = gravity.norm();
    return g > 0.f && -mNormal.dot(gravity) > 0.1f * g;
}

float BasalDrag::speedScale(float u, float h, float rho, float g, float gNormal, float dt) const {
    if (law == Boundary::Voellmy) return 1.f / (1.f + g * u * dt / (xi * h));
    if (law != Boundary::SamosAT || !(u > 0.f)) return 1.f;
    const float k = std::log(std::max(h / roughness, 1.f)) / kappa + b;
    const float turbulent = u / (1.f + u * dt / (h * k * k));
    const float sigmaOverRho = std::max(gNormal * h, 1e-6f); // sigma_b / rho, m^2/s^2
    const float rs = u * u / sigmaOverRho;
    const float coulombExtra = tau0 / (rho * h) + mu * gNormal * rs0 / (rs0 + rs);
    return std::max(0.f, turbulent - coulombExtra * dt) / u;
}

Vec3f BasalDrag::applied(const Vec3f& v, const Vec3f& n, float h, float rho, const Vec3f& gravity,
                         float dt) const {
    const Vec3f vt = v - v.dot(n) * n;
    const float scale =
        speedScale(vt.norm(), h, rho, gravity.norm(), std::max(-gravity.dot(n), 0.f), dt);
    return v - vt * (1.f - scale);
}

Vec3f Collider::applyBoundary(const Vec3f& v, const Vec3f& n) const {
    if (mBoundary == Boundary::Sticky) return Vec3f::Zero();
    const float vn = v.dot(n);
    if (vn >= 0.f) return v; // separating
    const Vec3f vt = v - vn * n;
    if (mBoundary == Boundary::Slip) return vt;
    // Coulomb: the normal impulse -vn buys at most mu |vn| of tangential impulse.
    const float vtNorm = vt.norm();
    if (vtNorm <= -mFriction * vn) return Vec3f::Zero();
    return vt * (1.f + mFriction * vn / vtNorm);
}

} // namespace firn
