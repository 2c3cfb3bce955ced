// Hazard runs as a practitioner runs them: the run ends itself once the avalanche has stopped.
// Reads what the step loop measured each frame and never changes the world.
#pragma once

#include <firn/serial.h>

#include <array>
#include <string>
#include <vector>

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

/// A horizontal line along an avalanche's path: (x, z) points in the simulation's frame, m, in
/// the direction of flow (AvaFrame's path_aimec; Lied and Bakkehoi 1980 measure alpha along it).
using PathLine = std::vector<std::array<double, 2>>;

/// Horizontal distance along `path` to the foot of the point (x, z) on it, m: the nearest point
/// of the polyline, its ends extended along their segments (a release's crown above the first
/// point, a runout past the last, measure beyond them). Consecutive equal points are skipped; a
/// path of fewer than two distinct points measures straight distance from its point.
double distanceAlongPath(const PathLine& path, double x, double z);

/// The runout along a path: the point of `footprint` ((x, y, z) cell centres, y the ground's
/// elevation) farthest along it, its distance along the path from the release's top `top`
/// (x, y, z), and the alpha angle of the line between them.
struct RunoutAlongPath {
    bool found = false;  ///< false for an empty footprint
    double length = 0.0; ///< m, horizontal, along the path from the top to the runout point
    std::array<double, 3> point = {0.0, 0.0, 0.0}; ///< x, y, z
    double alphaDeg = 0.0;                         ///< atan(drop / length), degrees
};
RunoutAlongPath runoutAlongPath(const PathLine& path, const std::array<double, 3>& top,
                                const std::vector<std::array<double, 3>>& footprint);

/// The path a flow took, from its centre of mass's track (x, z per frame): the track with the
/// points closer than `minStep` to the last kept one dropped (a resting deposit's jitter).
PathLine pathFromTrack(const PathLine& track, double minStep);

} // namespace firn
