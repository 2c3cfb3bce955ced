// Which frames the failure maps show.
#pragma once

#include <vector>

namespace firn::report {

/// Frames to map, ascending and distinct. `frames` are the particle cache frames and `times`
/// their simulated times (s, same length, ascending); `crackTip` is metrics.csv's crack_tip_x
/// for the same frames (NaN before the crack appears or without a weak layer).
///  - `requested` not empty: the frame nearest each requested time. A time more than half a
///    frame outside the run is a SceneError naming --times.
///  - else 4 frames evenly spaced while the crack runs, from its first appearance to the first
///    frame at which its tip is within `dx` of where it ends; over the whole run when there is
///    no crack or it never moves.
std::vector<int> chooseMapFrames(const std::vector<int>& frames, const std::vector<double>& times,
                                 const std::vector<double>& crackTip,
                                 const std::vector<double>& requested, double dx);

} // namespace firn::report
