// The explicit MPM step (Stomakhin et al. 2013; Jiang et al. 2016) with symplectic Euler, and
// the world it advances. scene -> buildWorld -> step loop -> output (design.md).
#pragma once

#include <firn/collider.h>
#include <firn/grid.h>
#include <firn/material.h>
#include <firn/node_contacts.h>
#include <firn/particles.h>
#include <firn/scene.h>
#include <firn/settle.h>
#include <firn/sticky_walls.h>
#include <firn/transfer.h>

#include <limits>
#include <memory>
#include <vector>

namespace firn {

/// The sleep pass's neighbour lists, kept while the particle leaves stay the same (the common
/// case once snow rests, when the pass would otherwise dominate a step).
struct SleepNeighbours {
    std::vector<LeafKey> leaves;                ///< the leaves the lists were built for
    std::vector<std::vector<std::uint32_t>> of; ///< per leaf, its existing neighbour leaves
};

struct World {
    int dim = 3;
    float dx = 0.05f;
    Transfer transfer = Transfer::Apic;
    float flipBlend = 0.95f;
    float flipRelaxationTime = 0.f; ///< s; > 0: blend exp(-dt / time) (GridDesc)
    int xpicOrder = 2;              ///< XPIC(m)'s m (GridDesc)
    float cfl = 0.4f;
    float maxDt = std::numeric_limits<float>::infinity(); ///< s (GridDesc::maxDt)
    Vec3f gravity = Vec3f(0.f, -9.81f, 0.f);
    float gravityRamp = 0.f;  ///< s, see SimulationDesc::gravityRamp
    bool sleep = true;        ///< see GridDesc::sleep
    float sleepSpeed = 0.02f; ///< m/s
    int sleepSteps = 100;
    /// The slip surface (firn/slip_contact.h): the material of the weak layer whose collapse
    /// releases it, or -1 for one velocity field; its Coulomb friction after the collapse.
    int slipMaterial = -1;
    float slipFriction = 0.f;

    std::vector<Material> materials;
    std::vector<std::size_t> particlesPerBody; ///< seeded particles of each scene body
    std::vector<Collider> colliders;
    ParticleSet particles;
    Grid grid;
    TransferScratch scratch;
    StickyWalls stickyWalls;   ///< the sticky colliders' ghost nodes of the current step
    NodeContacts nodeContacts; ///< the colliders' answers at the grid's nodes, kept per leaf
    SleepNeighbours sleepNeighbours;

    double time = 0.0; ///< s
    long long steps = 0;
    float maxSpeed = 0.f;     ///< largest particle speed after the last step, m/s
    float maxWaveSpeed = 0.f; ///< largest P-wave speed over the materials in use, m/s
    SettleReport settle;      ///< how the scene came to rest before t = 0
    Vec3f domainMin = Vec3f::Constant(-std::numeric_limits<float>::infinity()); ///< m
    Vec3f domainMax = Vec3f::Constant(std::numeric_limits<float>::infinity());  ///< m
    double outflowMass = 0.0; ///< kg (2D: per metre) removed for leaving the domain so far
    /// The local frame's origin in scene coordinates (SceneDesc::frameOrigin): outputs add it
    /// to every position, so that they are in the scene's (the DEM's) coordinates.
    Vec3d origin = {0.0, 0.0, 0.0};
};

/// How far buildWorld goes: to t = 0 as the scene asks (settled when simulation.settle), only
/// seeded (firn check: the particle counts without the cost of settling), or bare: materials
/// and colliders without particles (a resumed run loads its particles from a checkpoint).
enum class BuildStage { Bare, Seeded, Settled };

/// What buildWorld reports while it works, for a long run's progress; every member is optional.
struct BuildObserver {
    /// Polled while settling: true ends settling early (a signal asked the run to stop).
    std::function<bool()> interrupted;
    /// The colliders are built and no body is seeded yet (not called for BuildStage::Bare): what
    /// needs only the terrain (its export) runs here, and its transient memory is free again
    /// before the particles take theirs.
    std::function<void(const World&)> collidersBuilt;
    /// The bodies are seeded: how many particles, and the wall time it took, s.
    std::function<void(std::size_t particles, double seconds)> seeded;
    /// After every settling step (SettleParams::progress).
    std::function<void(const SettleProgress&)> settling;
};

/// Builds, in the scene's local frame (toLocalFrame, firn/gis.h), materials, colliders and seeds
/// particles from the scene's bodies (deterministic from simulation.seed); with BuildStage::Settled
/// and simulation.settle, settles the resting bodies under gravity (settleUnderGravity; bodies
/// seeded with a velocity join afterwards), then applies the saw cuts; `observer` hears how far it
/// got and can end settling early. Throws SceneError for what the scene asks and cannot be built.
std::unique_ptr<World> buildWorld(const SceneDesc& scene, BuildStage stage = BuildStage::Settled,
                                  const BuildObserver& observer = {});

/// The particles each body will seed, estimated from its shape on a lattice of at most ~2e5
/// points per body (no particle is made): within a few percent of buildWorld's count for bodies
/// many cells across, in well under a second at any dx. Throws SceneError as buildWorld does.
std::vector<double> estimateParticlesPerBody(const SceneDesc& scene);

/// dt = min(max_dt, cfl dx / (max speed + elastic wave speed)).
double stableTimeStep(const World& world);

/// Wall time per stage of the last steps, seconds (accumulated).
struct StepTimings {
    double p2g = 0, gridUpdate = 0, g2p = 0, plasticity = 0, sort = 0, sleep = 0;
};

/// One explicit step of length dt. Times each stage into `timings` when given.
void step(World& world, double dt, StepTimings* timings = nullptr);

/// Grid update: v = p / m + dt g (+ FLIP impulse), then the colliders' boundary conditions;
/// sticky colliders as a constraint folded into the update (firn/sticky_walls.h).
void updateGridVelocity(World& world, float dt);

/// Voellmy's turbulent basal friction (RAMMS; Salm 1993): a basal shear stress rho g u^2 / xi
/// against the sliding of snow over the `boundary = "voellmy"` terrain, spread over the flow's
/// depth as a depth-averaged model does: each column of dx (along y) that has snow within a
/// cell of the bed has flow thickness h = its particles' volume / dx^(d-1) x cos(slope), and
/// its awake particles lose tangential speed as du/dt = -g u^2 / (xi h), so the column's
/// momentum per unit bed area falls by rho g u^2 / xi (exact for a plug flow), whatever the
/// particles per cell or a small gap at the bed. Implicit, u' = u / (1 + g u dt / (xi h)): it
/// slows, never reverses. The Coulomb part mu sigma_n acts on the grid nodes as for `friction`.
void applyBasalDrag(World& world, float dt);

/// Return mapping and Kirchhoff stress of every awake particle from its trial F. `stateTime` is
/// the simulated time the new state belongs to (the end of the step): a slab particle that
/// fractures here, or a weak-layer particle the crack reaches, is stamped with it
/// (PlasticState::fractureTime).
void applyPlasticity(World& world, double stateTime);

/// Sleeping (GridDesc::sleep): puts to sleep the particles of leaves that, with all their
/// neighbours, have been slower than sleepSpeed for sleepSteps steps, and wakes the asleep
/// particles of leaves next to (or holding) a particle faster than that, or whose frozen snow
/// the grid pushes harder than kWakeAcceleration. Run after plasticity (step dt), when the
/// stress of every awake particle is current.
void updateSleep(World& world, float dt);

/// An asleep leaf whose block the grid accelerates by more than this (m/s^2, 5 % of g) wakes:
/// its load has changed. Slower pushes are the residual of freezing a state that was nearly,
/// not exactly, in equilibrium, which would otherwise wake deposits over and over.
constexpr float kWakeAcceleration = 0.49f;

/// Removes the particles outside [domainMin, domainMax] (snow that left the simulated region)
/// and adds their mass to outflowMass; returns how many went. Run between steps (at a frame's
/// end): it re-buckets the particles and recomputes their stress.
std::size_t removeOutflow(World& world);

/// Particles asleep after the last step.
std::size_t asleepCount(const World& world);

} // namespace firn
