// Per-frame measurements computed from the world (never changing it): conservation checks,
// energies, front and crack tip. Sums run per leaf and are added in leaf order, so they are the
// same for any thread count.
#pragma once

#include <firn/io.h>
#include <firn/serial.h>
#include <firn/solver.h>

#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace firn {

/// The crack times of a cell's cracked weak-layer particles: the earliest and the latest, s.
struct CellCrackTimes {
    float earliest = 0.f, latest = 0.f;
};

struct FrameDiagnostics {
    std::size_t particles = 0;
    double mass = 0; ///< kg (2D: per metre)
    Eigen::Vector3d centreOfMass = Eigen::Vector3d::Zero();
    Eigen::Vector3d momentum = Eigen::Vector3d::Zero();
    double kineticEnergy = 0;       ///< J
    double elasticEnergy = 0;       ///< J, Hencky energy of the elastic strains
    double gravitationalEnergy = 0; ///< J, -sum m g.x
    double maxSpeed = 0;            ///< m/s
    double topX = 0, topY = 0;      ///< highest particle, m
    double frontX = std::numeric_limits<double>::quiet_NaN(); ///< max x of moving snow (> 0.1 m/s)
    /// Snow that has moved (kFlagMoved): its highest particle (the release's top while it
    /// starts) and its farthest particle along x (the deposit's tip at the end), m; NaN if none.
    double movedTopX = std::numeric_limits<double>::quiet_NaN();
    double movedTopY = std::numeric_limits<double>::quiet_NaN();
    double movedTopZ = std::numeric_limits<double>::quiet_NaN(); ///< its z (3D)
    double movedFarX = std::numeric_limits<double>::quiet_NaN();
    double movedFarY = std::numeric_limits<double>::quiet_NaN();
    bool hasWeakLayer = false;
    /// Cells along x (width dx) that hold weak-layer particles with eta > 0, sorted, unique.
    std::vector<std::int64_t> crackCells;
    /// Per crackCells entry: the earliest time (s) a particle of the cell cracked
    /// (PlasticState::fractureTime); and the cells' width (dx), m.
    std::vector<float> crackCellTimes;
    double crackCellWidth = 0;
    /// 3D: the cells of the bed's plan (x, z; width dx) that hold weak-layer particles with
    /// eta > 0, sorted, unique, with their particles' crack times; empty in 2D.
    std::vector<std::pair<std::int64_t, std::int64_t>> crackPlanCells;
    std::vector<CellCrackTimes> crackPlanCellTimes;
    /// Extent along x of the crack: the largest run of crackCells with gaps of at most
    /// kCrackGapCells (isolated particles that yielded elsewhere are not the crack); NaN while
    /// none. Cell centres, m.
    double crackMinX = std::numeric_limits<double>::quiet_NaN();
    double crackMaxX = std::numeric_limits<double>::quiet_NaN();
    /// Cells along x (width dx) that hold weak-layer particles whose cohesion is gone
    /// (kFlagCollapsed: p0 reached 0, eq. 4), sorted, unique, and their extent as the crack's
    /// (the largest run, gaps of at most kCrackGapCells; NaN while none). The crack's extent is
    /// where softening has started (the paper's tip, eta > 0); this one is where it has finished:
    /// between the two ends lies the process zone.
    std::vector<std::int64_t> collapseCells;
    /// Extent along x of the weak-layer particles that have not cracked (eta = 0), m; NaN while
    /// none. The crack can only grow into it (CrackTracker).
    double intactMinX = std::numeric_limits<double>::quiet_NaN();
    double intactMaxX = std::numeric_limits<double>::quiet_NaN();
    double collapseMinX = std::numeric_limits<double>::quiet_NaN();
    double collapseMaxX = std::numeric_limits<double>::quiet_NaN();
    double failedFraction = 0; ///< failed mass / mass
    /// The slab's (Material::slab) mass, kg (2D: per metre), and momentum: their ratio is the
    /// velocity of its centre of mass, the speed at which the released slab moves off its bed.
    double slabMass = 0;
    Eigen::Vector3d slabMomentum = Eigen::Vector3d::Zero();
    /// Speed of the slab's centre of mass, m/s; NaN without a slab.
    double slabSpeed() const {
        return slabMass > 0 ? slabMomentum.norm() / slabMass
                            : std::numeric_limits<double>::quiet_NaN();
    }
    bool finite = true;                                      ///< every position and velocity finite
    Eigen::Vector3d worstPosition = Eigen::Vector3d::Zero(); ///< where the fastest or first
                                                             ///< non-finite particle is
    double totalEnergy() const { return kineticEnergy + elasticEnergy + gravitationalEnergy; }
};

/// Cells of failed weak layer further apart than this belong to different cracks.
constexpr std::int64_t kCrackGapCells = 3;

FrameDiagnostics computeDiagnostics(const World& world);

/// Crack tip and speed from the extent of weak-layer particles with eta > 0, frame by frame
/// (outputs.md: crack_tip_x, crack_speed; summary: max and mean crack speed, distance).
class CrackTracker {
public:
    /// The leading tip is the end of the eta > 0 extent that has propagated farther since the
    /// crack first appeared, counting only advances at kMinCrackSpeed or faster between frames
    /// (slower growth is creep, or failed weak layer carried by snow that flows); without such
    /// advances, the end that has grown more (down-slope, +x, on ties). Its speed is its advance
    /// between frames. An end grows (its propagation, distance(), meanSpeed(), its steps) only
    /// while weak layer that had not cracked lay beyond it in the frame before: past the layer's
    /// end, or over its cracked part, the extent moves with failed layer that flowing snow
    /// carries, at crack speed between some frames, and that is not the crack. An extent that
    /// does not overlap the previous one is a new crack: tracking restarts there.
    void update(const FrameDiagnostics& d, double time);
    double tip() const { return mTip; }     ///< m, NaN before the crack appears
    double speed() const { return mSpeed; } ///< m/s since the previous frame, NaN if none
    double maxSpeed() const { return mMaxSpeed; }
    /// Leading tip at `time`, m; NaN before the crack appears, the last tip after the last frame.
    /// Timed to the step where the frames carry crackCellTimes: the end of the extent as the
    /// cells cracked, step by step (a cell that cracked on its own ahead of the end joins when
    /// the end comes within kCrackGapCells of it, and no earlier than the frame before it
    /// joined); otherwise interpolated linearly between frames.
    double tipAt(double time) const;
    /// How far a point x lies behind the crack at `time`, m along x (> 0: the crack has passed
    /// it): measured from the end on x's side of where the crack started, once that end has
    /// propagated (an advance at kMinCrackSpeed or faster), otherwise from the leading tip. A
    /// crack that runs both ways from a trigger has two tips; a slab fracture up-slope of the
    /// trigger lies behind the up-slope one, even while the down-slope end leads. NaN before
    /// the crack appears. Ends timed to the step as tipAt.
    double distanceBehind(double x, double time) const;
    /// The leading end (direction()) timed to the step: (time, x) at each step it moved; empty
    /// where the frames carry no crackCellTimes.
    const std::vector<std::pair<double, double>>& tipSteps() const {
        return mDirection < 0 ? mUpSteps : mDownSteps;
    }
    /// Direction of travel of the leading tip along x: +1 down-slope, -1 up-slope, 0 before the
    /// crack appears.
    int direction() const { return mDirection; }
    /// Growth of the extent since its first appearance, m: each end as far as it grew (update).
    double distance() const;
    /// Steady crack speed, m/s: the leading end's mean speed over the middle 80 % of its travel
    /// (from where it started to the farthest an advance at crack speed into weak layer that
    /// had not cracked took it), 0.8 travel / (t90 - t10), with t10 and
    /// t90 the times it first passed 10 % and 90 % of the travel, interpolated between frames.
    /// This leaves out the onset at the cut and the arrival at the end of a column (both
    /// transients) and needs no more than two frames during the propagation.
    double meanSpeed() const;

    /// The whole state, for checkpoints: load(save()) continues exactly where save left off.
    void save(ByteWriter& out) const;
    void load(ByteReader& in);

private:
    double mMinX0 = std::numeric_limits<double>::quiet_NaN(), mMaxX0 = mMinX0;
    double mMinX = 0, mMaxX = 0, mTime = 0; // the ends as far as they grew (update)
    /// The extent of the uncracked weak layer in the last frame, m (NaN: none).
    double mIntactMinX = std::numeric_limits<double>::quiet_NaN(), mIntactMaxX = mIntactMinX;
    /// The farthest x each end reached by an advance at crack speed, m (NaN: none yet).
    double mUpReach = std::numeric_limits<double>::quiet_NaN(), mDownReach = mUpReach;
    double mTip = std::numeric_limits<double>::quiet_NaN(), mSpeed = mTip, mMaxSpeed = 0;
    int mDirection = 0;
    double mUpPropagated = 0, mDownPropagated = 0;   // m, advances at kMinCrackSpeed or faster
    std::vector<std::pair<double, double>> mHistory; // (time, leading tip x)
    std::vector<std::pair<double, double>> mUpHistory, mDownHistory; // (time, min / max x)
    /// (time, min / max x) of the extent at each step it grew, from the cells' crack times.
    std::vector<std::pair<double, double>> mUpSteps, mDownSteps;
    /// Appends to mUpSteps / mDownSteps the growth since the last frame (all of it for a new
    /// crack; of the ends that can grow, upGrows and downGrows, otherwise).
    void recordSteps(const FrameDiagnostics& d, bool fresh, bool upGrows = true,
                     bool downGrows = true);
    /// One end's x at `time` (side -1: the up-slope end, +1: the down-slope end).
    double endAt(double time, int side) const;
};

/// Where and when the weak layer cracked over the bed's plan (3D): for each (x, z) cell of dx,
/// the time its weak layer first cracked, the crack front's arrival (Gaume et al. 2019, Fig. A1).
/// A cell's time is the earliest crack time (PlasticState::fractureTime, timed to the step) of
/// its particles at the first frame that shows it cracked, and no earlier than the frame before.
/// A cell whose cracked particles all cracked before the frame before was not reached by the
/// crack: they were carried into it (a layer squeezed out at a free side, snow that slides), and
/// it is left out until a particle cracks in it.
class CrackArrivalMap {
public:
    struct Cell {
        std::int64_t x = 0, z = 0; ///< cell indices: the cell spans [x, x + 1) dx along x
        double time = 0;           ///< s
    };
    void update(const FrameDiagnostics& d, double time);
    /// The cells, sorted by x then z; empty before a crack and in 2D.
    const std::vector<Cell>& cells() const { return mCells; }
    double cellWidth() const { return mCellWidth; } ///< m

    void save(ByteWriter& out) const;
    void load(ByteReader& in);

private:
    std::vector<Cell> mCells;
    double mCellWidth = 0;
    double mLastFrameTime = -std::numeric_limits<double>::infinity();
};

/// Weak-layer cracks run at 20-150 m/s (field PSTs, Gaume et al. 2019); an end of the failed
/// extent that moves slower than this between frames is not propagating.
constexpr double kMinCrackSpeed = 10.0; // m/s

/// Energy can only leave the system (friction, plasticity, numerical damping). A gain larger
/// than everything the scene holds (initial kinetic + elastic energy, plus the potential energy
/// released so far, plus one cell of fall) means the integration has blown up.
class StabilityWatch {
public:
    StabilityWatch(const FrameDiagnostics& first, const World& world);
    /// Empty when fine, else a sentence saying what went wrong, when and where.
    std::string check(const FrameDiagnostics& d, const World& world) const;
    /// Total energy now minus at the start, J (negative: dissipated).
    double drift(const FrameDiagnostics& d) const { return d.totalEnergy() - mE0; }

    /// The watch's reference state, for checkpoints (it belongs to the run's first frame).
    void save(ByteWriter& out) const;
    void load(ByteReader& in);

private:
    double mE0, mBudget, mGravity0;
};

/// Alpha angle, degrees: from the highest point of the release (top) to the farthest point of
/// the deposit (far), from the horizontal. NaN when the deposit is not beyond the top along x.
double alphaAngleDeg(double topX, double topY, double farX, double farY);

/// A frame's diagnostics, for checkpoints.
void save(ByteWriter& out, const FrameDiagnostics& d);
void load(ByteReader& in, FrameDiagnostics& d);

/// Particle attributes of outputs.md for the particle cache (p, q from the stored Kirchhoff
/// stress as defined in the paper).
ParticleFrame exportParticles(const World& world);

} // namespace firn
