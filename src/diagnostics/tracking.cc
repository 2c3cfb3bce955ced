// Frame-to-frame tracking: crack tip and speed, the crack's arrival over the bed, the stability
// watch, the alpha angle.
#include <firn/diagnostics.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace firn {

namespace {
/// An advance of the crack's end by `advance` m in `dt` s is the crack running, not snow
/// carrying failed weak layer along.
bool atCrackSpeed(double advance, double dt) {
    return advance >= kMinCrackSpeed * dt;
}
} // namespace

void CrackTracker::update(const FrameDiagnostics& d, double time) {
    mSpeed = std::nan("");
    if (std::isnan(d.crackMinX)) return;
    // A crack that does not overlap the tracked one has become the largest (the tracked one was
    // a few particles that yielded under the static load, say): track the new one from here.
    const bool newCrack = !std::isnan(mMinX0) && (d.crackMinX > mMaxX || d.crackMaxX < mMinX);
    if (newCrack) {
        mMinX0 = std::nan("");
        mMaxSpeed = 0.0;
        mUpPropagated = mDownPropagated = 0.0;
        mUpReach = mDownReach = std::nan("");
        mHistory.clear(), mUpHistory.clear(), mDownHistory.clear();
        mUpSteps.clear(), mDownSteps.clear();
    }
    if (std::isnan(mMinX0)) {
        mUpHistory.push_back({time, d.crackMinX});
        mDownHistory.push_back({time, d.crackMaxX});
        recordSteps(d, true);
        mMinX0 = mMinX = d.crackMinX, mMaxX0 = mMaxX = d.crackMaxX;
        mTime = time;
        mTip = d.crackMaxX;
        mDirection = 1;
        mHistory.push_back({time, mTip});
        mIntactMinX = d.intactMinX, mIntactMaxX = d.intactMaxX;
        return;
    }
    // An end grows only into weak layer that had not cracked by the last frame (NaN, none left,
    // compares false): on scenes/slope2d.toml the failed layer that the avalanche carried past
    // the layer's end moved the extent from 20 to 25.5 m in 4 s, at 10-12.5 m/s between some
    // frames, and counted as crack it outweighed the 12.7 m the crack ran up-slope. An end that
    // cannot grow keeps its place, unless the extent shrank past it.
    const bool upGrows = mIntactMinX < mMinX;
    const bool downGrows = mIntactMaxX > mMaxX;
    const double minX = upGrows || d.crackMinX > mMinX ? d.crackMinX : mMinX;
    const double maxX = downGrows || d.crackMaxX < mMaxX ? d.crackMaxX : mMaxX;
    const double upAdvance = mMinX - minX, downAdvance = maxX - mMaxX;
    if (atCrackSpeed(upAdvance, time - mTime)) {
        mUpPropagated += upAdvance;
        mUpReach = std::isnan(mUpReach) ? minX : std::min(mUpReach, minX);
    }
    if (atCrackSpeed(downAdvance, time - mTime)) {
        mDownPropagated += downAdvance;
        mDownReach = std::isnan(mDownReach) ? maxX : std::max(mDownReach, maxX);
    }
    const bool upSlope = mUpPropagated != mDownPropagated ? mUpPropagated > mDownPropagated
                                                          : mMinX0 - minX > maxX - mMaxX0;
    const double advance = upSlope ? upAdvance : downAdvance;
    mTip = upSlope ? minX : maxX;
    mDirection = upSlope ? -1 : 1;
    mSpeed = std::max(0.0, advance) / (time - mTime);
    mMaxSpeed = std::max(mMaxSpeed, mSpeed);
    recordSteps(d, false, upGrows, downGrows);
    mMinX = minX, mMaxX = maxX, mTime = time;
    mIntactMinX = d.intactMinX, mIntactMaxX = d.intactMaxX;
    mUpHistory.push_back({time, mMinX});
    mDownHistory.push_back({time, mMaxX});
    mHistory.push_back({time, mTip});
}

double CrackTracker::distance() const {
    return std::isnan(mMinX0) ? 0.0 : (mMaxX - mMinX) - (mMaxX0 - mMinX0);
}

void CrackTracker::recordSteps(const FrameDiagnostics& d, bool fresh, bool upGrows,
                               bool downGrows) {
    if (d.crackCellTimes.size() != d.crackCells.size() || !(d.crackCellWidth > 0.0)) return;
    const double w = d.crackCellWidth;
    std::vector<std::pair<double, double>> grown; // (time, x) of the cells beyond the last extent
    for (std::size_t k = 0; k < d.crackCells.size(); ++k) {
        const double x = (double(d.crackCells[k]) + 0.5) * w;
        if (x < d.crackMinX || x > d.crackMaxX) continue;
        if (!fresh && x >= mMinX && x <= mMaxX) continue;
        // A cell that had cracked by the last frame but lay outside its extent (it cracked on
        // its own ahead of the tip, or snow that slides carried it here) joins after that frame.
        const double t = double(d.crackCellTimes[k]);
        grown.push_back({fresh ? t : std::max(t, mTime), x});
    }
    if (grown.empty()) return;
    std::sort(grown.begin(), grown.end());
    // The end moves to a cell when the cell cracks within reach of it (largestRun bridges
    // kCrackGapCells); a cell that cracked on its own farther ahead waits until the end comes
    // within reach, and joins then.
    const double reach = (double(kCrackGapCells) + 1.5) * w;
    auto advance = [&](std::vector<std::pair<double, double>>& steps, double end, double sign) {
        std::vector<double> pending;
        for (const auto& [t, x] : grown) {
            if (!(sign * (x - end) > 0.0)) continue;
            if (sign * (x - end) > reach) {
                pending.push_back(x);
                continue;
            }
            end = x;
            for (bool joined = true; joined;) {
                joined = false;
                for (double p : pending) {
                    if (sign * (p - end) > 0.0 && sign * (p - end) <= reach) end = p, joined = true;
                }
            }
            if (!steps.empty() && steps.back().first == t) {
                steps.back().second = end; // several cells in one step: the farthest
            } else {
                steps.push_back({t, end});
            }
        }
    };
    if (fresh) {
        // The crack starts where it cracked first.
        const auto& [t0, x0] = grown.front();
        mUpSteps.push_back({t0, x0}), mDownSteps.push_back({t0, x0});
        advance(mUpSteps, x0, -1.0), advance(mDownSteps, x0, 1.0);
    } else {
        if (upGrows) advance(mUpSteps, mMinX, -1.0);
        if (downGrows) advance(mDownSteps, mMaxX, 1.0);
    }
}

namespace {
/// The x of a (time, x) history at `time`: the entry at or before it (steps), or interpolated
/// between entries (frames); the last after the end, NaN before the start.
double historyAt(const std::vector<std::pair<double, double>>& history, double time,
                 bool interpolate) {
    if (history.empty() || time < history.front().first) return std::nan("");
    const auto after =
        std::upper_bound(history.begin(), history.end(), time,
                         [](double t, const auto& entry) { return t < entry.first; });
    if (!interpolate || after == history.end()) return (after - 1)->second;
    const auto& [t0, x0] = *(after - 1);
    const auto& [t1, x1] = *after;
    return x0 + (x1 - x0) * (time - t0) / (t1 - t0);
}
} // namespace

double CrackTracker::tipAt(double time) const {
    const auto& steps = tipSteps();
    if (!steps.empty()) return historyAt(steps, time, false);
    return historyAt(mHistory, time, true);
}

double CrackTracker::endAt(double time, int side) const {
    const auto& steps = side < 0 ? mUpSteps : mDownSteps;
    if (!steps.empty()) return historyAt(steps, time, false);
    return historyAt(side < 0 ? mUpHistory : mDownHistory, time, true);
}

double CrackTracker::distanceBehind(double x, double time) const {
    if (std::isnan(mMinX0) || mDirection == 0) return std::nan("");
    const int side = x < 0.5 * (mMinX0 + mMaxX0) ? -1 : 1;
    const bool propagated = side < 0 ? mUpPropagated > 0.0 : mDownPropagated > 0.0;
    // + 0.0: a fracture at the tip is 0, not -0, in summary.json.
    if (!propagated) return mDirection * (tipAt(time) - x) + 0.0;
    return side * (endAt(time, side) - x) + 0.0;
}

double CrackTracker::meanSpeed() const {
    const auto& history = mDirection < 0 ? mUpHistory : mDownHistory;
    if (history.size() < 2) return 0.0;
    // Distance along the direction of travel from the start. The travel is the farthest point
    // an advance at crack speed (kMinCrackSpeed or faster) into uncracked layer reached (update):
    // failed weak layer that released snow carries on afterwards is not the crack.
    const double sign = mDirection < 0 ? -1.0 : 1.0, x0 = history.front().second;
    const double travel = sign * ((mDirection < 0 ? mUpReach : mDownReach) - x0);
    if (!(travel > 0.0)) return 0.0;
    // The first time the end passed `fraction` of the travel, interpolated between frames.
    auto passed = [&](double fraction) {
        const double target = fraction * travel;
        for (std::size_t k = 1; k < history.size(); ++k) {
            const double a = sign * (history[k - 1].second - x0),
                         b = sign * (history[k].second - x0);
            if (b >= target && a < target) {
                const double t0 = history[k - 1].first, t1 = history[k].first;
                return t0 + (t1 - t0) * (target - a) / (b - a);
            }
        }
        return history.front().first;
    };
    const double t10 = passed(0.1), t90 = passed(0.9);
    return t90 > t10 ? 0.8 * travel / (t90 - t10) : 0.0;
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
    for (double v : {mMinX0, mMaxX0, mMinX, mMaxX, mTime, mTip, mSpeed, mMaxSpeed, mIntactMinX,
                     mIntactMaxX, mUpReach, mDownReach})
        out.value(v);
    out.value(mDirection);
    out.value(mUpPropagated), out.value(mDownPropagated);
    out.array(mHistory), out.array(mUpHistory), out.array(mDownHistory);
    out.array(mUpSteps), out.array(mDownSteps);
}

void CrackTracker::load(ByteReader& in) {
    for (double* v : {&mMinX0, &mMaxX0, &mMinX, &mMaxX, &mTime, &mTip, &mSpeed, &mMaxSpeed,
                      &mIntactMinX, &mIntactMaxX, &mUpReach, &mDownReach})
        in.value(*v);
    in.value(mDirection);
    in.value(mUpPropagated), in.value(mDownPropagated);
    in.array(mHistory), in.array(mUpHistory), in.array(mDownHistory);
    in.array(mUpSteps), in.array(mDownSteps);
}

void CrackArrivalMap::update(const FrameDiagnostics& d, double time) {
    mCellWidth = d.crackCellWidth;
    // Cells not in the map yet: both lists are sorted by (x, z).
    std::vector<Cell> added;
    auto known = mCells.begin();
    for (std::size_t k = 0; k < d.crackPlanCells.size(); ++k) {
        const auto [x, z] = d.crackPlanCells[k];
        known = std::lower_bound(
            known, mCells.end(), d.crackPlanCells[k],
            [](const Cell& c, const auto& key) { return std::make_pair(c.x, c.z) < key; });
        if (known != mCells.end() && known->x == x && known->z == z) continue;
        const CellCrackTimes& times = d.crackPlanCellTimes[k];
        if (double(times.latest) < mLastFrameTime) continue; // carried in, not reached
        added.push_back({x, z, std::max(double(times.earliest), mLastFrameTime)});
    }
    mLastFrameTime = time;
    if (added.empty()) return;
    std::vector<Cell> merged(mCells.size() + added.size());
    std::merge(mCells.begin(), mCells.end(), added.begin(), added.end(), merged.begin(),
               [](const Cell& a, const Cell& b) {
                   return std::make_pair(a.x, a.z) < std::make_pair(b.x, b.z);
               });
    mCells = std::move(merged);
}

void CrackArrivalMap::save(ByteWriter& out) const {
    out.array(mCells);
    out.value(mCellWidth), out.value(mLastFrameTime);
}

void CrackArrivalMap::load(ByteReader& in) {
    in.array(mCells);
    in.value(mCellWidth), in.value(mLastFrameTime);
}

void StabilityWatch::save(ByteWriter& out) const {
    for (double v : {mE0, mBudget, mGravity0}) out.value(v);
}

void StabilityWatch::load(ByteReader& in) {
    for (double* v : {&mE0, &mBudget, &mGravity0}) in.value(*v);
}

} // namespace firn
