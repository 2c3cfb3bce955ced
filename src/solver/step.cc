#include <firn/hencky.h>
#include <firn/slip_contact.h>
#include <firn/solver.h>
#include <firn/svd.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <unordered_map>

namespace firn {

namespace {

class StageClock {
public:
    explicit StageClock(double* sink)
        : mSink(sink)
        , mStart(std::chrono::steady_clock::now()) {}
    ~StageClock() {
        if (mSink)
            *mSink +=
                std::chrono::duration<double>(std::chrono::steady_clock::now() - mStart).count();
    }

private:
    double* mSink;
    std::chrono::steady_clock::time_point mStart;
};

Sym3f rotateDiagonal(const Mat3f& U, const Vec3f& d) {
    const Mat3f t = U * d.asDiagonal() * U.transpose();
    return Sym3f{t(0, 0), t(1, 1), t(2, 2), t(0, 1), t(0, 2), t(1, 2)};
}

/// Most particles are inside their yield surface with stretches near 1: there the Hencky strain
/// eps comes from a series (henckyStrainSeries, a batch at a time) and the stress needs no
/// principal decomposition. Returns false when the particle needs the full path (yielding).
bool elasticFastPath(const Material& mat, const Mat3f& eps, const PlasticState& state, int dim,
                     Sym3f& tau) {
    const float tr = eps.trace();
    const float devNorm = std::sqrt(std::max(0.f, eps.squaredNorm() - tr * tr / float(dim)));
    if (!staysElastic(mat, tr, devNorm, state)) return false;
    // tau = 2 mu eps + lambda tr(eps) I over the d x d block (the principal form rotated back)
    const float mu2 = 2.f * mat.lame.mu, ltr = mat.lame.lambda * tr;
    tau =
        Sym3f{mu2 * eps(0, 0) + ltr, mu2 * eps(1, 1) + ltr, dim == 3 ? mu2 * eps(2, 2) + ltr : 0.f,
              mu2 * eps(0, 1),       mu2 * eps(0, 2),       mu2 * eps(1, 2)};
    return true;
}

/// Stamps `time` on a snow particle the first time it counts as fractured (slabFractured), and
/// on a weak-layer particle the first time its eta exceeds 0, so that slab fractures and the
/// crack's arrival are timed to the step, not to the frame.
void markFractureTime(const Material& mat, double time, PlasticState& state) {
    if (mat.model == MaterialModel::WeakLayer) {
        if ((state.flags & kFlagCracked) || !(state.eta > 0.f)) return;
        state.flags |= kFlagCracked;
    } else {
        if ((state.flags & kFlagSlabFractured) || !slabFractured(mat, state)) return;
        state.flags |= kFlagSlabFractured;
    }
    state.fractureTime = float(time);
}

/// A mu(I) granular material with the friction angle of this particle's inertial number: the
/// shear rate sqrt(2 D':D') from the velocity gradient C of the last G2P (D its symmetric part,
/// zero out of plane in 2D), the pressure from the trial strain, p = -(lambda + 2 mu / 3) tr(eps)
/// in 3D and in plane strain alike.
Material atInertialNumber(const Material& mat, const Mat3f& C, const Vec3f& eps, int dim) {
    Mat3f D = Mat3f::Zero();
    D.topLeftCorner(dim, dim) =
        0.5f * (C.topLeftCorner(dim, dim) + C.topLeftCorner(dim, dim).transpose());
    const Mat3f deviator = D - (D.trace() / 3.f) * Mat3f::Identity();
    const float shearRate = std::sqrt(2.f * deviator.squaredNorm());
    float trEps = 0.f;
    for (int a = 0; a < dim; ++a) trEps += eps[a];
    Material rated = mat;
    rated.frictionAngleDeg =
        frictionAngleAt(mat, inertialNumber(mat, shearRate, -mat.lame.bulkModulus(3) * trEps));
    return rated;
}

} // namespace

double stableTimeStep(const World& world) {
    const double speed = double(world.maxSpeed) + double(world.maxWaveSpeed);
    if (speed <= 0.0) return world.maxDt;
    return std::min(double(world.maxDt), double(world.cfl) * world.dx / speed);
}

namespace {

/// The slip surface's normal at a node: the nearest terrain's (layers lie parallel to it), or
/// against gravity without terrain.
Vec3f slipNormal(const World& world, const Vec3f& xn) {
    if (world.colliders.size() == 1) return world.colliders.front().normal(xn);
    const Collider* nearest = nullptr;
    float distance = std::numeric_limits<float>::infinity();
    for (const Collider& c : world.colliders) {
        const float d = c.signedDistance(xn);
        if (d < distance) distance = d, nearest = &c;
    }
    if (nearest) return nearest->normal(xn);
    const float g = world.gravity.norm();
    return g > 0.f ? Vec3f(-world.gravity / g) : Vec3f(0.f, 1.f, 0.f);
}

} // namespace

void updateGridVelocity(World& world, float dt) {
    Grid& grid = world.grid;
    const bool flip = keepsReference(world.transfer);
    const AuxLayout layout{flip, world.slipMaterial >= 0};
    const int stride = layout.channels();
    const int nk = world.dim == 3 ? kLeafDim : 1;
    const float ramp =
        world.gravityRamp > 0.f ? std::min(1.f, float(world.time) / world.gravityRamp) : 1.f;
    const Vec3f dv = (dt * ramp) * world.gravity;
    NodeContacts& contacts = world.nodeContacts;
    contacts.bind(grid, world.colliders.size(), layout.twoFields);
    world.stickyWalls.fold(world.colliders, grid, contacts, world.dx, world.dim, flip, dv);
    const StickyWalls& walls = world.stickyWalls;
    const float tolerance = kContactTolerance * world.dx;
    const std::size_t colliderCount = world.colliders.size();
    // v = p / m (+ FLIP: the stress impulse / m, the velocity before forces kept as the
    // reference in its place) + dt g.
    auto withForces = [&](float m, const float* momentum, float* impulseInReferenceOut) {
        const float invM = 1.f / m;
        Vec3f vn(momentum[0] * invM, momentum[1] * invM, momentum[2] * invM);
        if (flip) {
            float* aux = impulseInReferenceOut;
            const Vec3f impulse(aux[0], aux[1], aux[2]);
            for (int c = 0; c < 3; ++c) aux[c] = vn[c];
            vn += invM * impulse;
        }
        return Vec3f(vn + dv);
    };
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, grid.blockCount(), 1), [&](const auto& r) {
        for (std::size_t b = r.begin(); b != r.end(); ++b) {
            const float* mass = grid.mass(b);
            float* vel = grid.velocity(b);
            float* aux = stride > 0 ? grid.aux(b) : nullptr;
            const LeafKey& key = grid.blockKey(b);
            for (int i = 0; i < kLeafDim; ++i)
                for (int j = 0; j < kLeafDim; ++j)
                    for (int k = 0; k < nk; ++k) {
                        const int n = (i << 6) | (j << 3) | k;
                        float* v = vel + 3 * n;
                        float* x = aux ? aux + stride * n : nullptr;
                        const float mUpper = layout.twoFields ? x[layout.upperMass()] : 0.f;
                        float* vUpperOut = layout.twoFields ? x + layout.upperVelocity() : nullptr;
                        if (mass[n] <= 0.f) v[0] = v[1] = v[2] = 0.f;
                        if (mUpper <= 0.f && vUpperOut)
                            vUpperOut[0] = vUpperOut[1] = vUpperOut[2] = 0.f;
                        const bool ghost = mass[n] > 0.f && walls.isGhost(b, n); // mirrored below
                        const bool lower = mass[n] > 0.f && !ghost;
                        const bool upper = mUpper > 0.f;
                        if (!lower && !upper) continue;
                        Vec3f vn = lower ? withForces(mass[n], v, x) : Vec3f(Vec3f::Zero());
                        Vec3f vUpper =
                            upper ? withForces(mUpper, vUpperOut, x + layout.upperReference())
                                  : Vec3f(Vec3f::Zero());
                        const Vec3f xn = nodePosition(key, i, j, k, world.dx, world.dim);
                        if (lower && upper) {
                            const Vec3f normal =
                                contacts.slipNormal(b, n, [&] { return slipNormal(world, xn); });
                            const FieldVelocities both =
                                resolveSlipContact(mass[n], vn, mUpper, vUpper, normal,
                                                   world.slipFriction, x[layout.bond()] > 0.5f);
                            vn = both.lower, vUpper = both.upper;
                        }
                        if (lower) {
                            // Sticky colliders were evaluated by the fold: their held nodes stop.
                            if (walls.isHeld(b, n)) vn = Vec3f::Zero();
                            for (std::size_t c = 0; c < colliderCount; ++c) {
                                const Collider& collider = world.colliders[c];
                                if (collider.mirrorsInside()) continue;
                                if (const auto normal =
                                        contacts.contact(b, n, c, collider, xn, tolerance))
                                    vn = collider.applyBoundary(vn, *normal);
                            }
                            v[0] = vn[0], v[1] = vn[1], v[2] = vn[2];
                        }
                        if (upper) {
                            // The upper field has no mirror: inside or on a sticky collider (and
                            // at the lower field's ghosts) it stops, as a zeroed node.
                            if (ghost) vUpper = Vec3f::Zero();
                            for (std::size_t c = 0; c < colliderCount; ++c)
                                if (const auto normal = contacts.contact(
                                        b, n, c, world.colliders[c], xn, tolerance))
                                    vUpper = world.colliders[c].applyBoundary(vUpper, *normal);
                            for (int c = 0; c < 3; ++c) vUpperOut[c] = vUpper[c];
                        }
                    }
        }
    });
    walls.mirror(grid, flip);
}

namespace {

/// The snow's columns of dx over a bed (x in 2D; x and z in 3D): the volume over each and whether
/// it touches the bed. A particle's column, its nearness to the bed and the bed's slope are found
/// in parallel; the volumes are summed in particle order (so bitwise the same for any thread
/// count), into a dense array over the particles' box of columns, or a hash map where that box is
/// far larger than the particle count (snow scattered far apart). The dense sums run in parallel
/// over ranges of columns, each range's task reading every particle's column and adding its own.
class BedColumns {
public:
    BedColumns(const ParticleSet& ps, const Collider& bed, float dx, bool is3d)
        : mColumnX(ps.size())
        , mColumnZ(ps.size())
        , mNearBed(ps.size())
        , mSlope(ps.size()) {
        const std::size_t n = ps.size();
        tbb::parallel_for(
            tbb::blocked_range<std::size_t>(0, n, 2048),
            [&](const auto& r) {
                for (std::size_t i = r.begin(); i != r.end(); ++i) {
                    mColumnX[i] = std::int64_t(std::floor(ps.x[i][0] / dx));
                    mColumnZ[i] = is3d ? std::int64_t(std::floor(ps.x[i][2] / dx)) : 0;
                    mNearBed[i] = bed.signedDistance(ps.x[i], mSlope[i]) < dx;
                }
            },
            tbb::simple_partitioner());
        if (n == 0) return;
        mMinX = *std::min_element(mColumnX.begin(), mColumnX.end());
        mMinZ = *std::min_element(mColumnZ.begin(), mColumnZ.end());
        mSpanX = *std::max_element(mColumnX.begin(), mColumnX.end()) - mMinX + 1;
        const std::int64_t spanZ = *std::max_element(mColumnZ.begin(), mColumnZ.end()) - mMinZ + 1;
        mDense = mSpanX * spanZ <= std::int64_t(8 * n + 65536);
        if (!mDense) {
            for (std::size_t i = 0; i < n; ++i) add(mScattered[key(i)], ps, i);
            return;
        }
        const std::size_t columns = std::size_t(mSpanX * spanZ);
        mColumns.resize(columns);
        mDenseIndex.resize(n);
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const auto& r) {
            for (std::size_t i = r.begin(); i != r.end(); ++i)
                mDenseIndex[i] =
                    std::uint32_t((mColumnZ[i] - mMinZ) * mSpanX + (mColumnX[i] - mMinX));
        });
        // One range a thread: each range's task reads every particle (the sums, in particle
        // order within each column, are the same for any count of ranges).
        const std::size_t pieces = std::clamp<std::size_t>(
            columns / 1024, 1, std::size_t(tbb::this_task_arena::max_concurrency()));
        tbb::parallel_for(std::size_t(0), pieces, [&](std::size_t piece) {
            const std::uint32_t lo = std::uint32_t(columns * piece / pieces),
                                hi = std::uint32_t(columns * (piece + 1) / pieces);
            for (std::size_t i = 0; i < n; ++i)
                if (mDenseIndex[i] >= lo && mDenseIndex[i] < hi)
                    add(mColumns[mDenseIndex[i]], ps, i);
        });
    }
    /// The column of particle i: its snow's volume (m^3, 2D: m^2) and whether it touches the bed.
    double volume(std::size_t i) const { return column(i).volume; }
    bool onBed(std::size_t i) const { return column(i).onBed; }
    /// What the bed's normal at particle i needs (Collider::normal(x, slope)).
    const Collider::Slope& slope(std::size_t i) const { return mSlope[i]; }

private:
    struct Column {
        double volume = 0.0;
        bool onBed = false;
    };
    void add(Column& c, const ParticleSet& ps, std::size_t i) const {
        c.volume += ps.volume0[i];
        c.onBed = c.onBed || mNearBed[i];
    }
    std::int64_t key(std::size_t i) const {
        return (mColumnX[i] << 32) ^ (mColumnZ[i] & 0xffffffff);
    }
    const Column& column(std::size_t i) const {
        return mDense ? mColumns[mDenseIndex[i]] : mScattered.find(key(i))->second;
    }

    std::vector<std::int64_t> mColumnX, mColumnZ;
    std::vector<std::uint8_t> mNearBed;
    std::vector<Collider::Slope> mSlope;
    std::vector<std::uint32_t> mDenseIndex;
    std::int64_t mMinX = 0, mMinZ = 0, mSpanX = 0;
    bool mDense = true;
    std::vector<Column> mColumns;
    std::unordered_map<std::int64_t, Column> mScattered;
};

} // namespace

void applyBasalDrag(World& world, float dt) {
    const float g = world.gravity.norm();
    const Collider* bed = nullptr;
    for (const Collider& c : world.colliders)
        if (c.basalDrag().active()) bed = &c;
    if (!bed || g <= 0.f) return;
    const BasalDrag& drag = bed->basalDrag();
    ParticleSet& ps = world.particles;
    const float dx = world.dx;
    const bool is3d = world.dim == 3;
    const BedColumns columns(ps, *bed, dx, is3d);
    const float area = is3d ? dx * dx : dx; // 2D: per metre of depth
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, ps.size(), 2048),
        [&](const auto& r) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) {
                if (ps.asleep(i)) continue;
                if (!columns.onBed(i)) continue; // airborne snow feels no bed
                const Vec3f n = bed->normal(ps.x[i], columns.slope(i));
                // Flow thickness normal to the bed: the column's vertical thickness times
                // cos(slope).
                const float h = float(columns.volume(i) / area) * std::max(n[1], 0.05f);
                ps.v[i] = drag.applied(ps.v[i], n, h, world.materials[ps.material[i]].density,
                                       world.gravity, dt);
            }
        },
        tbb::simple_partitioner());
}

// This loop, applyBasalDrag's and exportParticles' split their particle ranges with
// simple_partitioner: into pieces of the grain size at places that depend on the count alone, not
// on the thread count or on which thread stole what. A per-particle result then cannot depend on
// where its chunk starts (the Hencky batches start at chunk starts; a compiler may version a loop
// body), and the run stays bitwise the same for any thread count (applyBasalDrag once was not:
// BasalDrag::applied).
void applyPlasticity(World& world, double stateTime) {
    ParticleSet& ps = world.particles;
    const int dim = world.dim;
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, ps.size(), 2048),
        [&](const auto& r) {
            Mat3f series[kHenckyBatch], directions[kHenckyBatch];
            Vec3f principal[kHenckyBatch];
            unsigned inSeries = 0, decomposed = 0;
            bool batchDecomposed = false;
            for (std::size_t i = r.begin(); i != r.end(); ++i) {
                const std::size_t lane = (i - r.begin()) % kHenckyBatch;
                if (lane == 0) {
                    const int count = int(std::min<std::size_t>(kHenckyBatch, r.end() - i));
                    inSeries = henckyStrainSeries(&ps.H[i], count, dim, series);
                    batchDecomposed = false;
                    decomposed = 0;
                }
                if (ps.asleep(i)) continue;
                const Material& mat = world.materials[ps.material[i]];
                if ((inSeries >> lane & 1u) &&
                    elasticFastPath(mat, series[lane], ps.plastic[i], dim, ps.tau[i]))
                    continue;
                if (dim == 3 && !batchDecomposed) {
                    // 3D: the principal strains of the whole batch at once, when its first
                    // particle needs them (a batch costs about what one double eigenproblem of
                    // F F^T does): the series' strain decomposed directly, and the lanes too far
                    // from the identity for the series through F F^T - I. 2D keeps its
                    // closed-form 2 x 2.
                    const std::size_t first = i - lane;
                    const int count = int(std::min<std::size_t>(kHenckyBatch, r.end() - first));
                    const unsigned lanes = (1u << count) - 1u;
                    decomposed = principalHenckyStrains(&ps.H[first], series, inSeries, lanes,
                                                        directions, principal);
                    batchDecomposed = true;
                }
                Mat3f U;
                Vec3f eps = Vec3f::Zero();
                if (decomposed >> lane & 1u) {
                    U = directions[lane];
                    eps = principal[lane];
                } else {
                    const LeftStretch ls = leftStretch(ps.deformationGradient(i), dim);
                    U = ls.U;
                    for (int a = 0; a < dim; ++a) eps[a] = std::log(ls.sigma[a]);
                }
                if (mat.model != MaterialModel::Elastic) {
                    const ReturnMapResult rm =
                        mat.rateDependent() ? returnMap(atInertialNumber(mat, ps.C[i], eps, dim),
                                                        eps, ps.plastic[i])
                                            : returnMap(mat, eps, ps.plastic[i]);
                    ps.plastic[i] = rm.state;
                    markFractureTime(mat, stateTime, ps.plastic[i]);
                    if (rm.eps != eps) {
                        // Fe = U exp(eps) V^T = R Fe_trial with R = U diag(exp(eps) / sigma) U^T,
                        // as H <- H + (R - I)(I + H), R - I = U diag(expm1(eps - eps_trial)) U^T,
                        // which keeps a small return in H (ParticleSet::H).
                        Vec3f scaleMinusOne = Vec3f::Zero();
                        for (int a = 0; a < dim; ++a)
                            scaleMinusOne[a] = std::expm1(rm.eps[a] - eps[a]);
                        const Mat3f rotatedMinusI = U * scaleMinusOne.asDiagonal() * U.transpose();
                        ps.H[i] += rotatedMinusI + rotatedMinusI * ps.H[i];
                        eps = rm.eps;
                    }
                }
                ps.tau[i] = rotateDiagonal(U, kirchhoffPrincipal(mat.lame, eps, dim));
            }
        },
        tbb::simple_partitioner());
}

void step(World& world, double dt, StepTimings* timings) {
    const float dtf = static_cast<float>(dt);
    // A relaxation time makes the PIC share, and so the transfer's damping, a rate per
    // second: the same whatever dt the CFL number gives.
    const float flipBlend = world.flipRelaxationTime > 0.f
                                ? std::exp(-dtf / world.flipRelaxationTime)
                                : world.flipBlend;
    const TransferParams params{world.dim,          world.dx,       dtf, world.transfer, flipBlend,
                                world.slipMaterial, world.xpicOrder};
    {
        StageClock clock(timings ? &timings->p2g : nullptr);
        world.grid.rebuild(
            world.particles,
            AuxLayout{keepsReference(world.transfer), world.slipMaterial >= 0}.channels());
        particlesToGrid(world.particles, world.grid, params, world.scratch);
        if (world.transfer == Transfer::Xpic)
            xpicProjection(world.particles, world.grid, params, world.scratch);
    }
    {
        StageClock clock(timings ? &timings->gridUpdate : nullptr);
        updateGridVelocity(world, dtf);
    }
    {
        StageClock clock(timings ? &timings->g2p : nullptr);
        if (world.transfer == Transfer::Xpic) subtractXpicProjection(world.grid, world.scratch);
        world.maxSpeed = gridToParticles(world.particles, world.grid, params);
    }
    applyBasalDrag(world, dtf);
    {
        StageClock clock(timings ? &timings->sort : nullptr);
        world.particles.bucketByLeaf();
    }
    {
        StageClock clock(timings ? &timings->plasticity : nullptr);
        applyPlasticity(world, world.time + dt);
    }
    {
        StageClock clock(timings ? &timings->sleep : nullptr);
        updateSleep(world, dtf);
    }
    world.time += dt;
    ++world.steps;
}

} // namespace firn
