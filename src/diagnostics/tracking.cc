// Frame-to-frame tracking: crack tip and speed, the stability watch, the alpha angle.
#include <firn/diagnostics.h>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace firn {

void CrackTracker::update(const FrameDiagnostics& d, double time) {
    mSpeed = std::nan("");
    if (std::isnan(d.crackMinX)) return;
    // A crack that does not overlap the tracked one has become the largest (the tracked one was
    // a few particles that yielded under the static load, say): track the new one from here.
    const bool newCrack = !std::isnan(mMinX0) && (d.crackMinX > mMaxX || d.crackMaxX < mMinX);
    if (newCrack) {
        mMinX0 = std::nan("");
        mMaxSpeed = 0.0;
        mHistory.clear();
    }
    if (std::isnan(mMinX0)) {
        mMinX0 = mMinX = d.crackMinX, mMaxX0 = mMaxX = d.crackMaxX;
        mTime = time;
        mTip = d.crackMaxX;
        mDirection = 1;
        mHistory.push_back({time, mTip});
        return;
    }
    const bool upSlope = mMinX0 - d.crackMinX > d.crackMaxX - mMaxX0;
    const double advance = upSlope ? mMinX - d.crackMinX : d.crackMaxX - mMaxX;
    mTip = upSlope ? d.crackMinX : d.crackMaxX;
    mDirection = upSlope ? -1 : 1;
    mSpeed = std::max(0.0, advance) / (time - mTime);
    mMaxSpeed = std::max(mMaxSpeed, mSpeed);
    mMinX = d.crackMinX, mMaxX = d.crackMaxX, mTime = time;
    mHistory.push_back({time, mTip});
}

double CrackTracker::distance() const {
    return std::isnan(mMinX0) ? 0.0 : (mMaxX - mMinX) - (mMaxX0 - mMinX0);
}

double CrackTracker::tipAt(double time) const {
    if (mHistory.empty() || time < mHistory.front().first) return std::nan("");
    const auto after =
        std::upper_bound(mHistory.begin(), mHistory.end(), time,
                         [](double t, const auto& entry) { return t < entry.first; });
    if (after == mHistory.end()) return mHistory.back().second;
    const auto& [t0, x0] = *(after - 1);
    const auto& [t1, x1] = *after;
    return x0 + (x1 - x0) * (time - t0) / (t1 - t0);
}

double CrackTracker::meanSpeed() const {
    if (mHistory.size() < 3) return 0.0;
    const double x0 = mHistory.front().second, x1 = mHistory.back().second;
    const double lo = std::min(x0, x1) + 0.1 * std::abs(x1 - x0);
    const double hi = std::max(x0, x1) - 0.1 * std::abs(x1 - x0);
    double n = 0, st = 0, sx = 0, stt = 0, stx = 0;
    for (const auto& [t, x] : mHistory) {
        if (x < lo || x > hi) continue;
        n += 1, st += t, sx += x, stt += t * t, stx += t * x;
    }
    const double det = n * stt - st * st;
    return n >= 3 && det > 0 ? std::abs((n * stx - st * sx) / det) : 0.0;
}

StabilityWatch::StabilityWatch(const FrameDiagnostics& first, const World& world)
    : mE0(first.totalEnergy())
    , mBudget(first.kineticEnergy + first.elasticEnergy +
              first.mass * world.gravity.norm() * world.dx)
    , mGravity0(first.gravitationalEnergy) {}

std::string StabilityWatch::check(const FrameDiagnostics& d, const World& world) const {
    std::ostringstream why;
    const auto& p = d.worstPosition;
    if (!d.finite) {
        why << "non-finite particle state";
    } else {
        const double released = std::max(0.0, mGravity0 - d.gravitationalEnergy);
        const double gain = d.totalEnergy() - mE0;
        if (gain <= mBudget + released) return "";
        why << "energy grew by " << gain << " J without a source (budget " << mBudget + released
            << " J)";
    }
    why << " at t = " << world.time << " s, step " << world.steps << ", near x = (" << p[0] << ", "
        << p[1] << ", " << p[2] << ") m";
    return why.str();
}

double alphaAngleDeg(double topX, double topY, double farX, double farY) {
    const double run = farX - topX;
    if (!(run > 0)) return std::nan("");
    return std::atan2(topY - farY, run) * 180.0 / M_PI;
}

void CrackTracker::save(ByteWriter& out) const {
    for (double v : {mMinX0, mMaxX0, mMinX, mMaxX, mTime, mTip, mSpeed, mMaxSpeed}) out.value(v);
    out.value(mDirection);
    out.array(mHistory);
}

void CrackTracker::load(ByteReader& in) {
    for (double* v : {&mMinX0, &mMaxX0, &mMinX, &mMaxX, &mTime, &mTip, &mSpeed, &mMaxSpeed})
        in.value(*v);
    in.value(mDirection);
    in.array(mHistory);
}

void StabilityWatch::save(ByteWriter& out) const {
    for (double v : {mE0, mBudget, mGravity0}) out.value(v);
}

void StabilityWatch::load(ByteReader& in) {
    for (double* v : {&mE0, &mBudget, &mGravity0}) in.value(*v);
}

} // namespace firn
