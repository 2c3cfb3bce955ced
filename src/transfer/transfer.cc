#include <firn/bspline.h>
#include <firn/transfer.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace firn {

namespace {

constexpr int kPad = kLeafDim + 2; // a particle leaf reaches nodes 8k .. 8k + 9

template <int Dim> constexpr int paddedNodes() {
    return Dim == 3 ? kPad * kPad * kPad : kPad * kPad;
}

template <int Dim> inline int paddedIndex(int a, int b, int c) {
    return Dim == 3 ? (a * kPad + b) * kPad + c : a * kPad + b;
}

inline int leafOffset(int i, int j, int k) {
    return (i << 6) | (j << 3) | k;
}

/// Weights of a particle, with the base node relative to its leaf's first node.
struct Stencil {
    int base[3] = {0, 0, 0};
    float fx[3] = {1.f, 1.f, 1.f};
    float w[3][3] = {{0.f, 1.f, 0.f}, {0.f, 1.f, 0.f}, {0.f, 1.f, 0.f}};
};

template <int Dim> inline Stencil stencilOf(const Vec3f& x, float invDx, const LeafKey& leaf) {
    Stencil s;
    for (int a = 0; a < Dim; ++a) {
        const QuadraticWeights q = quadraticWeights(x[a] * invDx);
        s.base[a] = q.base - leaf[a] * kLeafDim;
        s.fx[a] = q.fx;
        s.w[a][0] = q.w[0], s.w[a][1] = q.w[1], s.w[a][2] = q.w[2];
    }
    return s;
}

/// Adds one particle's contribution to NC channels of the padded block, whose nodes are Stride
/// floats apart. The value at node (a, b, c) is value + affine (node - particle) = (value -
/// affine fx) + a col0 + b col1 + c col2 (grid units), built up incrementally across the loops
/// instead of a matrix-vector product per node.
template <int Dim, int NC, bool Affine, int AffineAt, int Stride = NC>
inline void scatterParticle(const Stencil& s, const float* value, const Mat3f& affine, float* buf) {
    float base[NC];
    for (int ch = 0; ch < NC; ++ch) base[ch] = value[ch];
    if (Affine) {
        const Vec3f shift = affine * Vec3f(s.fx[0], s.fx[1], Dim == 3 ? s.fx[2] : 0.f);
        for (int ch = 0; ch < 3; ++ch) base[AffineAt + ch] -= shift[ch];
    }
    constexpr int nc = Dim == 3 ? 3 : 1;
    for (int a = 0; a < 3; ++a) {
        for (int b = 0; b < 3; ++b) {
            const float wab = s.w[0][a] * s.w[1][b];
            float v[NC];
            for (int ch = 0; ch < NC; ++ch) v[ch] = base[ch];
            if (Affine)
                for (int ch = 0; ch < 3; ++ch)
                    v[AffineAt + ch] += float(a) * affine(ch, 0) + float(b) * affine(ch, 1);
            for (int c = 0; c < nc; ++c) {
                const float w = Dim == 3 ? wab * s.w[2][c] : wab;
                float* out =
                    buf + Stride * paddedIndex<Dim>(s.base[0] + a, s.base[1] + b, s.base[2] + c);
                for (int ch = 0; ch < NC; ++ch) out[ch] += w * v[ch];
                if (Affine && Dim == 3)
                    for (int ch = 0; ch < 3; ++ch) v[AffineAt + ch] += affine(ch, 2);
            }
        }
    }
}

/// Interpolates a particle's velocity (and FLIP increment) from the padded block, with the
/// APIC moment B = sum w v_i (x_i - x_p)^T in grid units. Moments are accumulated per axis
/// loop: column j of B is sum w v_i * index_j - fx_j * sum w v_i.
template <int Dim, bool Flip>
inline void gatherParticle(const Stencil& s, const float* local, int channels, Vec3f& vPic,
                           Mat3f& B, Vec3f& dvFlip) {
    constexpr int nc = Dim == 3 ? 3 : 1;
    Vec3f m0 = Vec3f::Zero(), m1 = Vec3f::Zero(), m2 = Vec3f::Zero();
    vPic.setZero();
    dvFlip.setZero();
    for (int a = 0; a < 3; ++a) {
        Vec3f sa = Vec3f::Zero(), sab = Vec3f::Zero(), sac = Vec3f::Zero(), dva = Vec3f::Zero();
        for (int b = 0; b < 3; ++b) {
            Vec3f sb = Vec3f::Zero(), sbc = Vec3f::Zero(), dvb = Vec3f::Zero();
            for (int c = 0; c < nc; ++c) {
                const float* g = local + channels * paddedIndex<Dim>(s.base[0] + a, s.base[1] + b,
                                                                     s.base[2] + c);
                const float wc = Dim == 3 ? s.w[2][c] : 1.f;
                const Vec3f wv = wc * Vec3f(g[0], g[1], g[2]);
                sb += wv;
                if (Dim == 3) sbc += float(c) * wv;
                if (Flip) dvb += wc * Vec3f(g[0] - g[3], g[1] - g[4], g[2] - g[5]);
            }
            const float wb = s.w[1][b];
            sa += wb * sb;
            sab += (wb * float(b)) * sb;
            sac += wb * sbc;
            if (Flip) dva += wb * dvb;
        }
        const float wa = s.w[0][a];
        vPic += wa * sa;
        m0 += (wa * float(a)) * sa;
        m1 += wa * sab;
        m2 += wa * sac;
        if (Flip) dvFlip += wa * dva;
    }
    B.col(0) = m0 - s.fx[0] * vPic;
    B.col(1) = m1 - s.fx[1] * vPic;
    B.col(2) = Dim == 3 ? Vec3f(m2 - s.fx[2] * vPic) : Vec3f::Zero();
}

/// Scatter phase into padded blocks of NC channels per node. ParticleFn(i, float* value, Mat3f&
/// affine) fills the constant part of the particle's channels and, if Affine, a matrix (per
/// metre) whose product with the node offset is added to its channels AffineAt .. AffineAt + 2;
/// it returns true for a particle of the upper field of a slip surface. A particle of the one
/// field (or the lower one) fills channels 0 .. UpperAt - 1, one of the upper field channels
/// UpperAt .. NC - 1 (value[0 ..], its affine part at AffineAt of them): each adds nothing to the
/// other field's channels, where its zeros would leave every sum bitwise as it is. With
/// skipDeepSleepers, leaves in deep sleep (ParticleSet::SleepLevel) scatter nothing: no awake
/// particle reads those nodes.
template <int Dim, int NC, bool Affine, int AffineAt, int UpperAt = NC, typename ParticleFn>
void scatterLeaves(const ParticleSet& ps, std::vector<float>& padded, bool skipDeepSleepers,
                   ParticleFn&& fn) {
    const std::size_t stride = std::size_t(paddedNodes<Dim>()) * NC;
    padded.assign(ps.leafCount() * stride, 0.f);
    const float invDx = 1.f / ps.dx;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, ps.leafCount(), 1), [&](const auto& r) {
        for (std::size_t l = r.begin(); l != r.end(); ++l) {
            if (skipDeepSleepers && ps.leafSleepLevel(l) == ParticleSet::kDeep) continue;
            float* buf = padded.data() + l * stride;
            for (std::uint32_t i = ps.leafStart[l]; i < ps.leafStart[l + 1]; ++i) {
                const Stencil s = stencilOf<Dim>(ps.x[i], invDx, ps.leaves[l]);
                float value[NC];
                Mat3f affine = Mat3f::Zero();
                const bool upper = fn(i, value, affine);
                if constexpr (UpperAt < NC) {
                    if (upper) {
                        scatterParticle<Dim, NC - UpperAt, Affine, AffineAt, NC>(
                            s, value, affine * ps.dx, buf + UpperAt);
                        continue;
                    }
                }
                scatterParticle<Dim, UpperAt, Affine, AffineAt, NC>(s, value, affine * ps.dx, buf);
            }
        }
    });
}

/// Node ranges of the overlap of particle leaf (block - o) with block, per axis.
inline int overlapEnd(int o, int axisBit) {
    return (o >> axisBit) & 1 ? 2 : kLeafDim;
}
inline int overlapShift(int o, int axisBit) {
    return (o >> axisBit) & 1 ? kLeafDim : 0;
}

/// Merge phase: every grid block sums its overlapping padded blocks in the fixed order
/// o = 0 .. 2^Dim - 1 into acc[512 * NC], then hands it to sink(b, acc).
template <int Dim, int NC, typename SinkFn>
void mergeBlocks(const Grid& grid, const std::vector<float>& padded, SinkFn&& sink) {
    const std::size_t stride = std::size_t(paddedNodes<Dim>()) * NC;
    const auto& sources = grid.particleLeavesOfBlock();
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, grid.blockCount(), 1), [&](const auto& r) {
        std::vector<float> acc(std::size_t(kLeafNodes) * NC);
        for (std::size_t b = r.begin(); b != r.end(); ++b) {
            std::fill(acc.begin(), acc.end(), 0.f);
            for (int o = 0; o < (1 << Dim); ++o) {
                const std::int32_t l = sources[b][o];
                if (l < 0) continue;
                const float* src = padded.data() + std::size_t(l) * stride;
                const int kEnd = Dim == 3 ? overlapEnd(o, 2) : 1;
                for (int i = 0; i < overlapEnd(o, 0); ++i)
                    for (int j = 0; j < overlapEnd(o, 1); ++j)
                        for (int k = 0; k < kEnd; ++k) {
                            const float* s = src + NC * paddedIndex<Dim>(i + overlapShift(o, 0),
                                                                         j + overlapShift(o, 1),
                                                                         k + overlapShift(o, 2));
                            float* d = acc.data() + NC * leafOffset(i, j, k);
                            for (int ch = 0; ch < NC; ++ch) d[ch] += s[ch];
                        }
            }
            sink(b, acc.data());
        }
    });
}

/// Copies 3 floats per node (from channel `channelOffset` of `sourceChannels` per node; field(b)
/// is block b's first node) of the 2^Dim blocks around particle leaf l into a padded local array
/// (10^Dim nodes of `channels` floats), so that G2P reads without per-node block lookups.
template <int Dim, typename FieldFn>
void gatherPadded(const Grid& grid, std::size_t l, FieldFn&& field, int sourceChannels,
                  int channelOffset, int channels, float* out) {
    const auto& blocks = grid.blocksOfParticleLeaf()[l];
    for (int o = 0; o < (1 << Dim); ++o) {
        const float* src = field(std::size_t(blocks[o]));
        const int kEnd = Dim == 3 ? overlapEnd(o, 2) : 1;
        for (int i = 0; i < overlapEnd(o, 0); ++i)
            for (int j = 0; j < overlapEnd(o, 1); ++j)
                for (int k = 0; k < kEnd; ++k) {
                    const float* s = src + sourceChannels * leafOffset(i, j, k) + channelOffset;
                    float* d = out + channels * paddedIndex<Dim>(i + overlapShift(o, 0),
                                                                 j + overlapShift(o, 1),
                                                                 k + overlapShift(o, 2));
                    for (int ch = 0; ch < 3; ++ch) d[ch] = s[ch];
                }
    }
}

Mat3f toMatrix(const Sym3f& t) {
    Mat3f m;
    m << t.xx, t.xy, t.xz, t.xy, t.yy, t.yz, t.xz, t.yz, t.zz;
    return m;
}

/// The MLS force as an affine momentum: -dt V0 tau D^-1 (x_i - x_p) per unit weight (Hu et al.
/// 2018, eq. 18), with dInv = D^-1.
inline Mat3f stressImpulse(const ParticleSet& ps, std::uint32_t i, float dt, float dInv) {
    return Mat3f((-dt * ps.volume0[i] * dInv) * toMatrix(ps.stress(i)));
}

/// P2G with a slip surface: each field gets its own mass, momentum and (FLIP) stress impulse, the
/// lower field in Grid::mass / velocity / aux as with one field, the upper one in Grid::aux
/// (AuxLayout), with the bond of every node from the weak layer's collapsed share of its mass.
/// The padded channels: the lower field, the weak layer's two masses (lower-field particles),
/// the upper field; a particle scatters only its own field's (scatterLeaves).
template <int Dim, bool Flip>
void p2gTwoFields(const ParticleSet& ps, Grid& grid, const TransferParams& params,
                  TransferScratch& scratch) {
    constexpr int perField = Flip ? 7 : 4; // mass, momentum, (stress impulse)
    constexpr int affineAt = Flip ? 4 : 1; // the stress impulse (with APIC's C on momentum)
    constexpr int weakAt = perField;       // the weak layer's mass, and its uncollapsed mass
    constexpr int upperAt = weakAt + 2;
    constexpr int NC = upperAt + perField;
    const float dInv = apicInverseD(1.f / params.dx);
    const bool apic = params.transfer == Transfer::Apic;
    scatterLeaves<Dim, NC, true, affineAt, upperAt>(
        ps, scratch.padded, true, [&](std::uint32_t i, float* value, Mat3f& affine) {
            const std::uint32_t flags = ps.plastic[i].flags;
            const bool upper = flags & kFlagUpperField;
            for (int ch = 0; ch < upperAt; ++ch) value[ch] = 0.f;
            const float m = ps.mass[i];
            value[0] = m, value[1] = m * ps.v[i][0], value[2] = m * ps.v[i][1];
            value[3] = m * ps.v[i][2];
            if (!upper && ps.material[i] == params.slipMaterial) {
                value[weakAt] = m;
                value[weakAt + 1] = (flags & kFlagCollapsed) ? 0.f : m;
            }
            affine = stressImpulse(ps, i, params.dt, dInv);
            if (!Flip && apic && !ps.asleep(i)) affine += m * ps.C[i];
            return upper;
        });
    const AuxLayout layout{Flip, true};
    const int stride = layout.channels();
    mergeBlocks<Dim, NC>(grid, scratch.padded, [&](std::size_t b, const float* acc) {
        float* mass = grid.mass(b);
        float* mom = grid.velocity(b);
        float* aux = grid.aux(b);
        for (int n = 0; n < kLeafNodes; ++n) {
            const float* a = acc + NC * n;
            float* x = aux + stride * n;
            mass[n] = a[0];
            for (int c = 0; c < 3; ++c) {
                mom[3 * n + c] = a[1 + c];
                if (Flip) x[layout.lowerReference() + c] = a[4 + c];
                x[layout.upperVelocity() + c] = a[upperAt + 1 + c];
                if (Flip) x[layout.upperReference() + c] = a[upperAt + 4 + c];
            }
            x[layout.upperMass()] = a[upperAt];
            x[layout.bond()] = a[weakAt + 1] > 0.5f * a[weakAt] ? 1.f : 0.f;
        }
    });
}

template <int Dim>
void p2g(const ParticleSet& ps, Grid& grid, const TransferParams& params,
         TransferScratch& scratch) {
    if (params.slipMaterial >= 0) {
        if (params.transfer == Transfer::Flip)
            return p2gTwoFields<Dim, true>(ps, grid, params, scratch);
        return p2gTwoFields<Dim, false>(ps, grid, params, scratch);
    }
    const float dInv = apicInverseD(1.f / params.dx);
    const bool apic = params.transfer == Transfer::Apic;
    if (!keepsReference(params.transfer)) {
        scatterLeaves<Dim, 4, true, 1>(
            ps, scratch.padded, true, [&](std::uint32_t i, float* value, Mat3f& affine) {
                const float m = ps.mass[i];
                value[0] = m, value[1] = m * ps.v[i][0], value[2] = m * ps.v[i][1];
                value[3] = m * ps.v[i][2];
                affine = stressImpulse(ps, i, params.dt, dInv);
                if (apic && !ps.asleep(i)) affine += m * ps.C[i];
                return false;
            });
        mergeBlocks<Dim, 4>(grid, scratch.padded, [&](std::size_t b, const float* acc) {
            float* mass = grid.mass(b);
            float* mom = grid.velocity(b);
            for (int n = 0; n < kLeafNodes; ++n) {
                mass[n] = acc[4 * n];
                for (int c = 0; c < 3; ++c) mom[3 * n + c] = acc[4 * n + 1 + c];
            }
        });
        return;
    }
    // FLIP and XPIC keep the transferred momentum and the stress impulse apart: the grid
    // velocity before forces is the reference of their increment.
    scatterLeaves<Dim, 7, true, 4>(
        ps, scratch.padded, true, [&](std::uint32_t i, float* value, Mat3f& affine) {
            const float m = ps.mass[i];
            value[0] = m, value[1] = m * ps.v[i][0], value[2] = m * ps.v[i][1];
            value[3] = m * ps.v[i][2], value[4] = value[5] = value[6] = 0.f;
            affine = stressImpulse(ps, i, params.dt, dInv);
            return false;
        });
    mergeBlocks<Dim, 7>(grid, scratch.padded, [&](std::size_t b, const float* acc) {
        float* mass = grid.mass(b);
        float* mom = grid.velocity(b);
        float* impulse = grid.aux(b);
        for (int n = 0; n < kLeafNodes; ++n) {
            mass[n] = acc[7 * n];
            for (int c = 0; c < 3; ++c) {
                mom[3 * n + c] = acc[7 * n + 1 + c];
                impulse[3 * n + c] = acc[7 * n + 4 + c];
            }
        }
    });
}

/// Mass-weighted mean velocity of the nodes of grid block b (both fields of a slip surface).
inline Vec3f meanBlockVelocity(const Grid& grid, std::int32_t b, const AuxLayout& layout) {
    const float* mass = grid.mass(std::size_t(b));
    const float* vel = grid.velocity(std::size_t(b));
    Vec3f momentum = Vec3f::Zero();
    float total = 0.f;
    for (int n = 0; n < kLeafNodes; ++n) {
        if (mass[n] <= 0.f) continue;
        momentum += mass[n] * Vec3f(vel[3 * n], vel[3 * n + 1], vel[3 * n + 2]);
        total += mass[n];
    }
    if (layout.twoFields) {
        const float* aux = grid.aux(std::size_t(b));
        const int stride = layout.channels();
        for (int n = 0; n < kLeafNodes; ++n) {
            const float* x = aux + stride * n;
            const float m = x[layout.upperMass()];
            if (m <= 0.f) continue;
            const float* v = x + layout.upperVelocity();
            momentum += m * Vec3f(v[0], v[1], v[2]);
            total += m;
        }
    }
    return total > 0.f ? Vec3f(momentum / total) : Vec3f(Vec3f::Zero());
}

template <int Dim, bool Flip>
float g2p(ParticleSet& ps, const Grid& grid, const TransferParams& params) {
    const float invDx = 1.f / ps.dx;
    const float cScale = apicInverseD(invDx) * ps.dx; // C = 4/dx^2 B with offsets in grid units
    const float dt = params.dt, flip = params.flipBlend;
    const bool xpic = params.transfer == Transfer::Xpic;
    const AuxLayout layout{Flip, params.slipMaterial >= 0};
    const int auxStride = layout.channels();
    const auto velocityField = [&grid](std::size_t b) { return grid.velocity(b); };
    const auto auxField = [&grid](std::size_t b) { return grid.aux(b); };
    return tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, ps.leafCount(), 1), 0.f,
        [&](const auto& r, float maxSpeed) {
            constexpr int channels = Flip ? 6 : 3;
            float local[paddedNodes<Dim>() * channels];
            float upperLocal[paddedNodes<Dim>() * channels]; // the upper field's, if any
            for (std::size_t l = r.begin(); l != r.end(); ++l) {
                const auto sleep = ps.leafSleepLevel(l);
                if (sleep != ParticleSet::kAwake) { // at rest, state frozen
                    // Next to awake snow it watches for a push; deeper in, its block's nodes
                    // lack the scatter of deep leaves (P2G), and nothing is read.
                    if (sleep == ParticleSet::kAsleep)
                        ps.leafPush[l] =
                            meanBlockVelocity(grid, grid.blocksOfParticleLeaf()[l][0], layout);
                    continue;
                }
                // With a slip surface, only the fields that the leaf's awake particles read.
                bool readsLower = !layout.twoFields, readsUpper = false;
                for (std::uint32_t i = ps.leafStart[l]; layout.twoFields && i < ps.leafStart[l + 1];
                     ++i) {
                    if (ps.asleep(i)) continue;
                    (ps.plastic[i].flags & kFlagUpperField ? readsUpper : readsLower) = true;
                }
                if (readsLower) {
                    gatherPadded<Dim>(grid, l, velocityField, 3, 0, channels, local);
                    if (Flip)
                        gatherPadded<Dim>(grid, l, auxField, auxStride, layout.lowerReference(),
                                          channels, local + 3);
                }
                if (readsUpper) {
                    gatherPadded<Dim>(grid, l, auxField, auxStride, layout.upperVelocity(),
                                      channels, upperLocal);
                    if (Flip)
                        gatherPadded<Dim>(grid, l, auxField, auxStride, layout.upperReference(),
                                          channels, upperLocal + 3);
                }
                for (std::uint32_t i = ps.leafStart[l]; i < ps.leafStart[l + 1]; ++i) {
                    if (ps.asleep(i)) continue;
                    const Stencil s = stencilOf<Dim>(ps.x[i], invDx, ps.leaves[l]);
                    Vec3f vPic, dvFlip;
                    Mat3f B;
                    const bool upper = layout.twoFields && (ps.plastic[i].flags & kFlagUpperField);
                    gatherParticle<Dim, Flip>(s, upper ? upperLocal : local, channels, vPic, B,
                                              dvFlip);
                    const Mat3f C = cScale * B;
                    ps.C[i] = C;
                    // XPIC: the reference is v^L - v* (xpicReference), the increment its update.
                    ps.v[i] = !Flip  ? vPic
                              : xpic ? dvFlip
                                     : Vec3f(flip * (ps.v[i] + dvFlip) + (1.f - flip) * vPic);
                    ps.x[i] += dt * vPic;
                    // Fe <- (I + dt C) Fe, as H <- H + dt C (I + H) so that a strain increment
                    // far below float spacing at 1 is kept (ParticleSet::H).
                    const Mat3f dtC = dt * C;
                    ps.H[i] += dtC + dtC * ps.H[i];
                    const float speed = ps.v[i].norm();
                    if (speed > kMovedSpeed) ps.plastic[i].flags |= kFlagMoved;
                    // NaN compares false: make it win the reduction so the caller sees it.
                    maxSpeed = speed == speed ? std::max(maxSpeed, speed)
                                              : std::numeric_limits<float>::quiet_NaN();
                    if (maxSpeed != maxSpeed) return maxSpeed;
                }
            }
            return maxSpeed;
        },
        [](float a, float b) { return (a != a || b != b) ? a + b : std::max(a, b); });
}

/// S w at a particle: a 3-channel node field of the padded block interpolated.
template <int Dim> inline Vec3f interpolate(const Stencil& s, const float* local) {
    constexpr int nc = Dim == 3 ? 3 : 1;
    Vec3f sum = Vec3f::Zero();
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
            const float wab = s.w[0][a] * s.w[1][b];
            for (int c = 0; c < nc; ++c) {
                const float* g =
                    local + 3 * paddedIndex<Dim>(s.base[0] + a, s.base[1] + b, s.base[2] + c);
                const float w = Dim == 3 ? wab * s.w[2][c] : wab;
                sum += w * Vec3f(g[0], g[1], g[2]);
            }
        }
    return sum;
}

/// XPIC(m) (Hammerquist & Nairn 2017): v* = sum_{k<m} (I - S+ S)^k v^L, term by term, from the
/// transferred grid velocity v^L = S+ v_p of P2G (before the sticky walls' fold and mirror, which
/// would make v^L other than S+ v_p and let the sum amplify the difference m-fold). S+ S is a
/// round trip through the particles that P2G scattered (every leaf not in deep sleep), with their
/// mass scattered beside the momentum so that S+ divides by the mass it sums.
template <int Dim>
void xpic(const ParticleSet& ps, const Grid& grid, const TransferParams& params,
          TransferScratch& scratch) {
    const std::size_t blocks = grid.blockCount();
    std::vector<float>& term = scratch.xpicTerm;
    std::vector<float>& sum = scratch.xpicSum;
    term.assign(blocks * kLeafNodes * 3, 0.f);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks, 16), [&](const auto& r) {
        for (std::size_t b = r.begin(); b != r.end(); ++b)
            for (int n = 0; n < kLeafNodes; ++n) {
                const float m = grid.mass(b)[n];
                if (m <= 0.f) continue;
                for (int c = 0; c < 3; ++c)
                    term[(b * kLeafNodes + n) * 3 + c] = grid.velocity(b)[3 * n + c] / m;
            }
    });
    sum = term;
    std::vector<Vec3f>& atParticles = scratch.xpicAtParticles;
    atParticles.resize(ps.size());
    const float invDx = 1.f / ps.dx;
    const auto termField = [&term](std::size_t b) { return term.data() + b * kLeafNodes * 3; };
    for (int k = 1; k < params.xpicOrder; ++k) {
        tbb::parallel_for(
            tbb::blocked_range<std::size_t>(0, ps.leafCount(), 1), [&](const auto& r) {
                float local[paddedNodes<Dim>() * 3];
                for (std::size_t l = r.begin(); l != r.end(); ++l) {
                    if (ps.leafSleepLevel(l) == ParticleSet::kDeep) continue;
                    gatherPadded<Dim>(grid, l, termField, 3, 0, 3, local);
                    for (std::uint32_t i = ps.leafStart[l]; i < ps.leafStart[l + 1]; ++i)
                        atParticles[i] =
                            interpolate<Dim>(stencilOf<Dim>(ps.x[i], invDx, ps.leaves[l]), local);
                }
            });
        scatterLeaves<Dim, 4, false, 0>(ps, scratch.padded, true,
                                        [&](std::uint32_t i, float* value, Mat3f&) {
                                            const float m = ps.mass[i];
                                            value[0] = m;
                                            for (int c = 0; c < 3; ++c)
                                                value[1 + c] = m * atParticles[i][c];
                                            return false;
                                        });
        mergeBlocks<Dim, 4>(grid, scratch.padded, [&](std::size_t b, const float* acc) {
            for (int n = 0; n < kLeafNodes; ++n) {
                const float m = acc[4 * n];
                float* t = term.data() + (b * kLeafNodes + n) * 3;
                float* total = sum.data() + (b * kLeafNodes + n) * 3;
                for (int c = 0; c < 3; ++c) {
                    t[c] = m > 0.f ? t[c] - acc[4 * n + 1 + c] / m : 0.f;
                    total[c] += t[c];
                }
            }
        });
    }
}

template <int Dim>
VolumeFrame rasterize(const ParticleSet& ps, const Grid& grid, TransferScratch& scratch) {
    scatterLeaves<Dim, 6, false, 0>(
        ps, scratch.padded, false, [&](std::uint32_t i, float* value, Mat3f&) {
            const float m = ps.mass[i];
            value[0] = m, value[1] = m * ps.v[i][0], value[2] = m * ps.v[i][1];
            value[3] = m * ps.v[i][2];
            value[4] = (ps.plastic[i].flags & kFlagFailed) ? m : 0.f;
            value[5] = m * ps.plastic[i].eta;
            return false;
        });
    VolumeFrame vf;
    vf.voxelSize = ps.dx;
    const std::size_t nb = grid.blockCount();
    vf.origin.resize(nb);
    vf.density.assign(nb * kLeafNodes, 0.f);
    vf.velocity.assign(nb * kLeafNodes, {0.f, 0.f, 0.f});
    vf.failed.assign(nb * kLeafNodes, 0.f);
    vf.eta.assign(nb * kLeafNodes, 0.f);
    const float cellVolume = Dim == 3 ? ps.dx * ps.dx * ps.dx : ps.dx * ps.dx;
    mergeBlocks<Dim, 6>(grid, scratch.padded, [&](std::size_t b, const float* acc) {
        const LeafKey& k = grid.blockKey(b);
        vf.origin[b] = {k[0] * kLeafDim, k[1] * kLeafDim, k[2] * kLeafDim};
        for (int n = 0; n < kLeafNodes; ++n) {
            const float m = acc[6 * n];
            if (m <= 0.f) continue;
            const std::size_t at = b * kLeafNodes + n;
            vf.density[at] = m / cellVolume;
            vf.velocity[at] = {acc[6 * n + 1] / m, acc[6 * n + 2] / m, acc[6 * n + 3] / m};
            vf.failed[at] = std::min(1.f, acc[6 * n + 4] / m);
            vf.eta[at] = acc[6 * n + 5] / m;
        }
    });
    return vf;
}

} // namespace

void particlesToGrid(const ParticleSet& particles, Grid& grid, const TransferParams& params,
                     TransferScratch& scratch) {
    if (params.dim == 2) return p2g<2>(particles, grid, params, scratch);
    p2g<3>(particles, grid, params, scratch);
}

void xpicProjection(const ParticleSet& particles, const Grid& grid, const TransferParams& params,
                    TransferScratch& scratch) {
    if (params.dim == 2) return xpic<2>(particles, grid, params, scratch);
    xpic<3>(particles, grid, params, scratch);
}

void subtractXpicProjection(Grid& grid, const TransferScratch& scratch) {
    const int stride = grid.auxChannels();
    const std::vector<float>& sum = scratch.xpicSum;
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, grid.blockCount(), 16), [&](const auto& r) {
            for (std::size_t b = r.begin(); b != r.end(); ++b)
                for (int n = 0; n < kLeafNodes; ++n)
                    for (int c = 0; c < 3; ++c)
                        grid.aux(b)[stride * n + c] -= sum[(b * kLeafNodes + n) * 3 + c];
        });
}

float gridToParticles(ParticleSet& particles, const Grid& grid, const TransferParams& params) {
    const bool flip = keepsReference(params.transfer);
    if (params.dim == 2)
        return flip ? g2p<2, true>(particles, grid, params)
                    : g2p<2, false>(particles, grid, params);
    return flip ? g2p<3, true>(particles, grid, params) : g2p<3, false>(particles, grid, params);
}

VolumeFrame rasterizeVolumes(const ParticleSet& particles, const Grid& grid,
                             TransferScratch& scratch) {
    if (particles.dim == 2) return rasterize<2>(particles, grid, scratch);
    return rasterize<3>(particles, grid, scratch);
}

} // namespace firn
