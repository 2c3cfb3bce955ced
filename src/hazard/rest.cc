#include <firn/hazard.h>

#include <algorithm>
#include <cmath>

namespace firn {

bool RestDetector::atRest(double kineticEnergy, double comPathLength) {
    if (!std::isfinite(kineticEnergy)) return false; // the stability watch reports it
    mLast = kineticEnergy;
    mPeak = std::max(mPeak, kineticEnergy);
    mReleased = mReleased || comPathLength >= mMoveDistance;
    return mReleased && mPeak > 0.0 && kineticEnergy < mFraction * mPeak;
}

void RestDetector::save(ByteWriter& out) const {
    out.value(mPeak);
    out.value(mLast);
    out.value(mReleased);
}

void RestDetector::load(ByteReader& in) {
    in.value(mPeak);
    in.value(mLast);
    in.value(mReleased);
}

} // namespace firn
