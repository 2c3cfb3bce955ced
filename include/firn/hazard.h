// Hazard runs as a practitioner runs them: the run ends itself once the avalanche has stopped.
// Reads what the step loop measured each frame and never changes the world.
#pragma once

#include <firn/serial.h>

#include <string>

namespace firn {

/// Why a run ended (summary.json `stop_reason`).
inline constexpr const char* kStopEndTime = "end_time";
inline constexpr const char* kStopAtRest = "at_rest";

/// AvaFrame's stop criterion (com1DFA `stopCrit`): the flow has stopped once its kinetic energy
/// falls below `fraction` of the largest it has had. Fed once per frame, so the peak is the
/// largest frame value (a step's peak between frames can only be larger: the run then stops a
/// frame later, never earlier). Two guards keep a run that never flowed from ending: the centre
/// of mass must first travel `moveDistance` (one cell: a settled slope creeps far less), and the
/// peak must be positive.
class RestDetector {
public:
    RestDetector(double fraction, double moveDistance)
        : mFraction(fraction)
        , mMoveDistance(moveDistance) {}

    /// One frame: the kinetic energy (J; 2D: per metre) and the centre of mass's horizontal path
    /// length so far (m). True once the flow has stopped.
    bool atRest(double kineticEnergy, double comPathLength);

    double peakKineticEnergy() const { return mPeak; }
    /// The last frame's kinetic energy over the peak (1 before anything moved).
    double ratio() const { return mPeak > 0.0 ? mLast / mPeak : 1.0; }
    /// Whether the release has moved (the criterion applies from then on).
    bool released() const { return mReleased; }

    void save(ByteWriter& out) const;
    void load(ByteReader& in);

private:
    double mFraction;
    double mMoveDistance;
    double mPeak = 0.0;
    double mLast = 0.0;
    bool mReleased = false;
};

} // namespace firn
