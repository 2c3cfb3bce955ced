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

/// NodeBox of the particles of leaf l for which include(i) holds. A thin flow fills few of a
/// leaf's cells (`path3d`: 174 particles in 4 096 cells), and the padded block's zeroing, the
/// merge and G2P's gather then touch only these nodes.
template <int Dim, typename IncludeFn>
NodeBox nodeBoxOf(const ParticleSet& ps, std::size_t l, float invDx, IncludeFn&& include) {
    NodeBox box;
    int lo[3] = {kPad, kPad, kPad}, hi[3] = {-1, -1, -1};
    static_assert(kPad < (1 << 20), "NodeBox's empty lo");
    for (std::uint32_t i = ps.leafStart[l]; i < ps.leafStart[l + 1]; ++i) {
        if (!include(i)) continue;
        for (int a = 0; a < Dim; ++a) {
            const int base = static_cast<int>(std::floor(ps.x[i][a] * invDx - 0.5f)) -
                             ps.leaves[l][a] * kLeafDim;
            lo[a] = std::min(lo[a], base);
            hi[a] = std::max(hi[a], base + 2);
        }
    }
    if (lo[0] > hi[0]) return box;
    for (int a = 0; a < 3; ++a) {
        box.lo[a] = a < Dim ? lo[a] : 0;
        box.hi[a] = a < Dim ? hi[a] : 0;
    }
    return box;
}

/// Floats per node of a padded P2G block with NC channels: NC rounded up to whole packets of 4,
/// so that a particle adds all of a node's channels as SSE or AVX packets (the extra channels
/// stay zero).
template <int NC> constexpr int packedChannels() {
    return (NC + 3) & ~3;
}

/// The node layout of a padded P2G block whose particles fill channels 0 .. UpperAt - 1 (one
/// field, or the lower field of a slip surface) or UpperAt .. NC - 1 (the upper field): each
/// field's channels start on a packet boundary, so a particle adds its own field as whole
/// packets and nothing to the other's.
template <int NC, int UpperAt> struct PaddedLayout {
    static constexpr bool twoFields = UpperAt < NC;
    static constexpr int lowerLanes = packedChannels<UpperAt>();
    static constexpr int upperLanes = twoFields ? packedChannels<NC - UpperAt>() : 0;
    static constexpr int upperAt = lowerLanes; ///< where the upper field's channels start
    static constexpr int lanes = lowerLanes + upperLanes;
};

using Lanes4 = float __attribute__((vector_size(4 * sizeof(float))));
using Lanes8 = float __attribute__((vector_size(8 * sizeof(float))));

/// Copies Width floats (a multiple of 4) to `out` as whole 8- and 4-float vector stores built
/// from the scalars in registers, so that an Eigen packet load of them is forwarded from the
/// stores (each load within one store) instead of waiting for them to reach the cache.
template <int Width> inline void storeWhole(const float* in, float* out) {
    int q = 0;
    for (; q + 8 <= Width; q += 8) {
        const Lanes8 v = {in[q],     in[q + 1], in[q + 2], in[q + 3],
                          in[q + 4], in[q + 5], in[q + 6], in[q + 7]};
        __builtin_memcpy(out + q, &v, sizeof(v));
    }
    for (; q + 4 <= Width; q += 4) {
        const Lanes4 v = {in[q], in[q + 1], in[q + 2], in[q + 3]};
        __builtin_memcpy(out + q, &v, sizeof(v));
    }
}

/// Adds one particle's contribution to Width channels of the padded block (value zero past the
/// particle's own channels), whose nodes are Stride floats apart: one packet per node. The value
/// at node (a, b, c) is value + affine (node - particle) = (value - affine fx) + a col0 + b col1
/// + c col2 (grid units), built up incrementally across the loops instead of a matrix-vector
/// product per node.
template <int Dim, int Width, bool Affine, int AffineAt, int Stride>
inline void scatterParticle(const Stencil& s, const float* value, const Mat3f& affine, float* buf) {
    using Packet = Eigen::Matrix<float, Width, 1>;
    // The packets are assembled from scalars and stored whole (storeWhole) before Eigen loads
    // them: lanes written one by one into an Eigen packet in memory and then loaded as one
    // packet stall on store forwarding (perf of slope2d's P2G: about a third of its set-up).
    float lanes[Width], colLanes[3][Width] = {};
    for (int ch = 0; ch < Width; ++ch) lanes[ch] = value[ch];
    if (Affine) {
        const Vec3f shift = affine * Vec3f(s.fx[0], s.fx[1], Dim == 3 ? s.fx[2] : 0.f);
        for (int ch = 0; ch < 3; ++ch) lanes[AffineAt + ch] -= shift[ch];
        for (int k = 0; k < 3; ++k)
            for (int ch = 0; ch < 3; ++ch) colLanes[k][AffineAt + ch] = affine(ch, k);
    }
    alignas(32) float staged[4][Width];
    storeWhole<Width>(lanes, staged[0]);
    for (int k = 0; k < 3; ++k) storeWhole<Width>(colLanes[k], staged[1 + k]);
    Packet base = Eigen::Map<const Packet>(staged[0]);
    const Packet col[3] = {Eigen::Map<const Packet>(staged[1]), Eigen::Map<const Packet>(staged[2]),
                           Eigen::Map<const Packet>(staged[3])};
    constexpr int nc = Dim == 3 ? 3 : 1;
    for (int a = 0; a < 3; ++a) {
        for (int b = 0; b < 3; ++b) {
            const float wab = s.w[0][a] * s.w[1][b];
            Packet v = base;
            if (Affine) v += float(a) * col[0] + float(b) * col[1];
            for (int c = 0; c < nc; ++c) {
                const float w = Dim == 3 ? wab * s.w[2][c] : wab;
                Eigen::Map<Packet> out(
                    buf + Stride * paddedIndex<Dim>(s.base[0] + a, s.base[1] + b, s.base[2] + c));
                out += w * v;
                if (Affine && Dim == 3) v += col[2];
            }
        }
    }
}

/// G2P's padded block: per node the grid velocity in lanes 0-2 and, for FLIP, its increment v -
/// v_ref in lanes 4-6 (lanes 3 and 7 zero), so that a node is one packet of 4 or 8 floats and
/// every sum below runs on whole packets (SSE or AVX) instead of three scalars.
template <bool Flip> constexpr int g2pLanes() {
    return Flip ? 8 : 4;
}
template <bool Flip> using G2pPacket = Eigen::Matrix<float, g2pLanes<Flip>(), 1>;

/// Interpolates a particle's velocity (and FLIP increment) from the padded block, with the
/// APIC moment B = sum w v_i (x_i - x_p)^T in grid units. Moments are accumulated per axis
/// loop: column j of B is sum w v_i * index_j - fx_j * sum w v_i.
template <int Dim, bool Flip>
inline void gatherParticle(const Stencil& s, const float* local, Vec3f& vPic, Mat3f& B,
                           Vec3f& dvFlip) {
    using Packet = G2pPacket<Flip>;
    constexpr int lanes = g2pLanes<Flip>();
    constexpr int nc = Dim == 3 ? 3 : 1;
    Packet v = Packet::Zero(), m0 = Packet::Zero(), m1 = Packet::Zero(), m2 = Packet::Zero();
    for (int a = 0; a < 3; ++a) {
        Packet sa = Packet::Zero(), sab = Packet::Zero(), sac = Packet::Zero();
        for (int b = 0; b < 3; ++b) {
            Packet sb = Packet::Zero(), sbc = Packet::Zero();
            for (int c = 0; c < nc; ++c) {
                const Packet g = Eigen::Map<const Packet>(
                    local + lanes * paddedIndex<Dim>(s.base[0] + a, s.base[1] + b, s.base[2] + c));
                const float wc = Dim == 3 ? s.w[2][c] : 1.f;
                const Packet wv = wc * g;
                sb += wv;
                if (Dim == 3) sbc += float(c) * wv;
            }
            const float wb = s.w[1][b];
            sa += wb * sb;
            sab += (wb * float(b)) * sb;
            sac += wb * sbc;
        }
        const float wa = s.w[0][a];
        v += wa * sa;
        m0 += (wa * float(a)) * sa;
        m1 += wa * sab;
        m2 += wa * sac;
    }
    vPic = v.template head<3>();
    if (Flip) dvFlip = v.template segment<3>(4);
    B.col(0) = m0.template head<3>() - s.fx[0] * vPic;
    B.col(1) = m1.template head<3>() - s.fx[1] * vPic;
    B.col(2) = Dim == 3 ? Vec3f(m2.template head<3>() - s.fx[2] * vPic) : Vec3f::Zero();
}

/// gatherParticle for two 3D particles at once, without FLIP (4 lanes a node): particle a in
/// the low four floats of an AVX packet, b in the high four, so that each instruction does both
/// particles' work. The stencil's sums are chains of dependent multiply-adds; one particle at a
/// time they wait on each other's latency with half of each packet idle (perf of firn_bench's
/// G2P), two at a time both halves work in each step of the chain. Lane by lane the arithmetic
/// is gatherParticle's.
inline void gatherParticlePair(const Stencil& sa, const float* localA, const Stencil& sb,
                               const float* localB, Vec3f vPic[2], Mat3f B[2]) {
    using Pair = float __attribute__((vector_size(8 * sizeof(float))));
    using Quad = float __attribute__((vector_size(4 * sizeof(float))));
    const auto both = [](float x, float y) { return Pair{x, x, x, x, y, y, y, y}; };
    const auto node = [](const float* p) {
        Quad q;
        __builtin_memcpy(&q, p, sizeof(q));
        return q;
    };
    Pair v = {}, m0 = {}, m1 = {}, m2 = {};
    for (int a = 0; a < 3; ++a) {
        Pair sumA = {}, sumAB = {}, sumAC = {};
        for (int b = 0; b < 3; ++b) {
            Pair sumB = {}, sumBC = {};
            for (int c = 0; c < 3; ++c) {
                const Quad ga = node(
                    localA + 4 * paddedIndex<3>(sa.base[0] + a, sa.base[1] + b, sa.base[2] + c));
                const Quad gb = node(
                    localB + 4 * paddedIndex<3>(sb.base[0] + a, sb.base[1] + b, sb.base[2] + c));
                const Pair g = __builtin_shufflevector(ga, gb, 0, 1, 2, 3, 4, 5, 6, 7);
                const Pair wv = both(sa.w[2][c], sb.w[2][c]) * g;
                sumB += wv;
                sumBC += float(c) * wv;
            }
            const Pair wb = both(sa.w[1][b], sb.w[1][b]);
            sumA += wb * sumB;
            sumAB += (wb * float(b)) * sumB;
            sumAC += wb * sumBC;
        }
        const Pair wa = both(sa.w[0][a], sb.w[0][a]);
        v += wa * sumA;
        m0 += (wa * float(a)) * sumA;
        m1 += wa * sumAB;
        m2 += wa * sumAC;
    }
    const Stencil* s[2] = {&sa, &sb};
    for (int p = 0; p < 2; ++p) {
        const int o = 4 * p;
        vPic[p] = Vec3f(v[o], v[o + 1], v[o + 2]);
        B[p].col(0) = Vec3f(m0[o], m0[o + 1], m0[o + 2]) - s[p]->fx[0] * vPic[p];
        B[p].col(1) = Vec3f(m1[o], m1[o + 1], m1[o + 2]) - s[p]->fx[1] * vPic[p];
        B[p].col(2) = Vec3f(m2[o], m2[o + 1], m2[o + 2]) - s[p]->fx[2] * vPic[p];
    }
}

/// Scatter phase into padded blocks laid out as PaddedLayout<NC, UpperAt>. ParticleFn(i, float*
/// value, Mat3f& affine), value zeroed, fills the constant part of the particle's channels and, if
/// Affine, a matrix (per metre) whose product with the node offset is added to its channels
/// AffineAt .. AffineAt + 2; it returns true for a particle of the upper field of a slip surface. A
/// particle of the one field (or the lower one) fills channels 0 .. UpperAt - 1 of value, one of
/// the upper field its NC - UpperAt channels from value[0] (its affine part at AffineAt of them),
/// which land at the layout's upperAt: each adds nothing to the other field's channels. With
/// skipDeepSleepers, leaves in deep sleep (ParticleSet::SleepLevel) scatter nothing: no awake
/// particle reads those nodes.
template <int Dim, int NC, bool Affine, int AffineAt, int UpperAt = NC, typename ParticleFn>
void scatterLeaves(const ParticleSet& ps, PaddedBlocks& padded, bool skipDeepSleepers,
                   ParticleFn&& fn) {
    using Layout = PaddedLayout<NC, UpperAt>;
    constexpr int lanes = Layout::lanes;
    const std::size_t stride = std::size_t(paddedNodes<Dim>()) * lanes;
    padded.values.resize(ps.leafCount() * stride);
    padded.boxes.resize(ps.leafCount());
    const float invDx = 1.f / ps.dx;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, ps.leafCount(), 1), [&](const auto& r) {
        for (std::size_t l = r.begin(); l != r.end(); ++l) {
            NodeBox& box = padded.boxes[l];
            box = NodeBox{};
            if (skipDeepSleepers && ps.leafSleepLevel(l) == ParticleSet::kDeep) continue;
            box = nodeBoxOf<Dim>(ps, l, invDx, [](std::uint32_t) { return true; });
            // Each leaf zeroes its own block's reached nodes (the merge reads no others): in
            // parallel, and into the cache it scatters in.
            float* buf = padded.values.data() + l * stride;
            for (int a = box.lo[0]; a <= box.hi[0]; ++a)
                for (int b = box.lo[1]; b <= box.hi[1]; ++b)
                    std::fill_n(buf + lanes * paddedIndex<Dim>(a, b, box.lo[2]),
                                lanes * (box.hi[2] - box.lo[2] + 1), 0.f);
            for (std::uint32_t i = ps.leafStart[l]; i < ps.leafStart[l + 1]; ++i) {
                const Stencil s = stencilOf<Dim>(ps.x[i], invDx, ps.leaves[l]);
                float value[lanes] = {};
                Mat3f affine = Mat3f::Zero();
                const bool upper = fn(i, value, affine);
                if constexpr (Layout::twoFields) {
                    if (upper) {
                        scatterParticle<Dim, Layout::upperLanes, Affine, AffineAt, lanes>(
                            s, value, affine * ps.dx, buf + Layout::upperAt);
                        continue;
                    }
                }
                scatterParticle<Dim, Layout::lowerLanes, Affine, AffineAt, lanes>(
                    s, value, affine * ps.dx, buf);
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

/// The padded nodes (per axis from..to inclusive) that both overlap grid block o of a particle
/// leaf (o's bit a: the block one leaf up along axis a) and lie in `box`.
struct PaddedRange {
    int from[3], to[3];
    bool empty() const { return from[0] > to[0] || from[1] > to[1] || from[2] > to[2]; }
};
template <int Dim> PaddedRange overlapInBox(int o, const NodeBox& box) {
    PaddedRange r;
    for (int a = 0; a < 3; ++a) {
        const int shift = a < Dim ? overlapShift(o, a) : 0;
        const int end = a < Dim ? overlapEnd(o, a) : 1;
        r.from[a] = std::max(shift, box.lo[a]);
        r.to[a] = std::min(shift + end - 1, box.hi[a]);
    }
    return r;
}

/// The node of grid block o (as in overlapInBox) at padded node (i, j, k).
template <int Dim> int blockNodeOfPadded(int o, int i, int j, int k) {
    return leafOffset(i - overlapShift(o, 0), j - overlapShift(o, 1),
                      Dim == 3 ? k - overlapShift(o, 2) : 0);
}

/// Calls fn(n) for the nodes of a grid block that a Dim-dimensional run uses: all 512 in 3D,
/// the 64 of its z = 0 plane in 2D (the others stay zero: nothing scatters to them).
template <int Dim, typename Fn> inline void forEachNode(Fn&& fn) {
    if (Dim == 3) {
        for (int n = 0; n < kLeafNodes; ++n) fn(n);
        return;
    }
    for (int i = 0; i < kLeafDim; ++i)
        for (int j = 0; j < kLeafDim; ++j) fn(leafOffset(i, j, 0));
}

/// Merge phase: every grid block sums its overlapping padded blocks in the fixed order
/// o = 0 .. 2^Dim - 1 into acc[512 * packedChannels<NC>()], then hands it to sink(b, acc).
template <int Dim, int NC, typename SinkFn>
void mergeBlocks(const Grid& grid, const PaddedBlocks& padded, SinkFn&& sink) {
    constexpr int PC = packedChannels<NC>();
    const std::size_t stride = std::size_t(paddedNodes<Dim>()) * PC;
    const auto& sources = grid.particleLeavesOfBlock();
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, grid.blockCount(), 1), [&](const auto& r) {
        alignas(32) float acc[kLeafNodes * PC]; // on the stack: no allocation per block
        for (std::size_t b = r.begin(); b != r.end(); ++b) {
            forEachNode<Dim>([&](int n) { std::fill_n(acc + PC * n, PC, 0.f); });
            for (int o = 0; o < (1 << Dim); ++o) {
                const std::int32_t l = sources[b][o];
                if (l < 0) continue;
                const float* src = padded.values.data() + std::size_t(l) * stride;
                // The overlap of the source's reached nodes with this block, in the source's
                // padded coordinates (nodes outside it hold zero: adding them changed nothing).
                const PaddedRange range = overlapInBox<Dim>(o, padded.boxes[std::size_t(l)]);
                for (int i = range.from[0]; i <= range.to[0]; ++i)
                    for (int j = range.from[1]; j <= range.to[1]; ++j)
                        for (int k = range.from[2]; k <= range.to[2]; ++k) {
                            const float* s = src + PC * paddedIndex<Dim>(i, j, k);
                            float* d = acc + PC * blockNodeOfPadded<Dim>(o, i, j, k);
                            // one packet add per node (a loop over channels stayed scalar:
                            // the compiler could not rule out that acc and src overlap)
                            Eigen::Map<Eigen::Matrix<float, PC, 1>>(d) +=
                                Eigen::Map<const Eigen::Matrix<float, PC, 1>>(s);
                        }
            }
            sink(b, static_cast<const float*>(acc));
        }
    });
}

/// Copies 3 floats per node (from channel `channelOffset` of `sourceChannels` per node; field(b)
/// is block b's first node) of the 2^Dim blocks around particle leaf l into a padded local array
/// (10^Dim nodes of `channels` floats), so that G2P reads without per-node block lookups.
template <int Dim, typename FieldFn>
void gatherPadded(const Grid& grid, std::size_t l, const NodeBox& box, FieldFn&& field,
                  int sourceChannels, int channelOffset, int channels, float* out) {
    const auto& blocks = grid.blocksOfParticleLeaf()[l];
    for (int o = 0; o < (1 << Dim); ++o) {
        // The overlap of block o with the nodes the particles read, in padded coordinates.
        const PaddedRange range = overlapInBox<Dim>(o, box);
        if (range.empty()) continue;
        const float* src = field(std::size_t(blocks[o]));
        for (int i = range.from[0]; i <= range.to[0]; ++i)
            for (int j = range.from[1]; j <= range.to[1]; ++j)
                for (int k = range.from[2]; k <= range.to[2]; ++k) {
                    const float* s =
                        src + sourceChannels * blockNodeOfPadded<Dim>(o, i, j, k) + channelOffset;
                    float* d = out + channels * paddedIndex<Dim>(i, j, k);
                    for (int ch = 0; ch < 3; ++ch) d[ch] = s[ch];
                    if (channels > 3) d[3] = 0.f; // G2P's packets: a defined lane past the three
                }
    }
}

/// FLIP's padded block: lanes 4-6 of every node from the reference velocity to the increment
/// v - v_ref that G2P adds to the particle's velocity.
template <int Dim> void toIncrement(const NodeBox& box, float* local) {
    for (int a = box.lo[0]; a <= box.hi[0]; ++a)
        for (int b = box.lo[1]; b <= box.hi[1]; ++b)
            for (int c = box.lo[2]; c <= box.hi[2]; ++c) {
                float* node = local + 8 * paddedIndex<Dim>(a, b, c);
                for (int ch = 0; ch < 3; ++ch) node[4 + ch] = node[ch] - node[4 + ch];
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
    using Padded = PaddedLayout<NC, upperAt>;
    const AuxLayout layout{Flip, true};
    const int stride = layout.channels();
    mergeBlocks<Dim, Padded::lanes>(grid, scratch.padded, [&](std::size_t b, const float* acc) {
        float* mass = grid.mass(b);
        float* mom = grid.velocity(b);
        float* aux = grid.aux(b);
        forEachNode<Dim>([&](int n) {
            const float* a = acc + Padded::lanes * n;
            const float* up = a + Padded::upperAt;
            float* x = aux + stride * n;
            mass[n] = a[0];
            for (int c = 0; c < 3; ++c) {
                mom[3 * n + c] = a[1 + c];
                if (Flip) x[layout.lowerReference() + c] = a[4 + c];
                x[layout.upperVelocity() + c] = up[1 + c];
                if (Flip) x[layout.upperReference() + c] = up[4 + c];
            }
            x[layout.upperMass()] = up[0];
            x[layout.bond()] = a[weakAt + 1] > 0.5f * a[weakAt] ? 1.f : 0.f;
        });
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
            forEachNode<Dim>([&](int n) {
                mass[n] = acc[4 * n];
                for (int c = 0; c < 3; ++c) mom[3 * n + c] = acc[4 * n + 1 + c];
            });
        });
        return;
    }
    // FLIP and XPIC keep the transferred momentum and the stress impulse apart: the grid
    // velocity before forces is the reference of their increment.
    scatterLeaves<Dim, 7, true, 4>(
        ps, scratch.padded, true, [&](std::uint32_t i, float* value, Mat3f& affine) {
            const float m = ps.mass[i];
            value[0] = m, value[1] = m * ps.v[i][0], value[2] = m * ps.v[i][1];
            value[3] = m * ps.v[i][2];
            affine = stressImpulse(ps, i, params.dt, dInv);
            return false;
        });
    mergeBlocks<Dim, 7>(grid, scratch.padded, [&](std::size_t b, const float* acc) {
        float* mass = grid.mass(b);
        float* mom = grid.velocity(b);
        float* impulse = grid.aux(b);
        constexpr int pc = packedChannels<7>();
        forEachNode<Dim>([&](int n) {
            mass[n] = acc[pc * n];
            for (int c = 0; c < 3; ++c) {
                mom[3 * n + c] = acc[pc * n + 1 + c];
                impulse[3 * n + c] = acc[pc * n + 4 + c];
            }
        });
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

/// G2P's update of C and H = Fe - I in plane strain, from C's in-plane entries c_ab: only the
/// upper-left 2 x 2 blocks of C and dt C H are non-zero there (C's third row and column are,
/// and H's off-plane entries stay, zero), so four entries are updated instead of nine with
/// 3 x 3 products. H_zz is unchanged: plane strain.
inline void updateAffinePlane(float c00, float c01, float c10, float c11, float dt, Mat3f& C,
                              Mat3f& H) {
    C << c00, c01, 0.f, c10, c11, 0.f, 0.f, 0.f, 0.f;
    const float d00 = dt * c00, d01 = dt * c01, d10 = dt * c10, d11 = dt * c11;
    const float h00 = H(0, 0), h01 = H(0, 1), h10 = H(1, 0), h11 = H(1, 1);
    H(0, 0) = h00 + (d00 + (d00 * h00 + d01 * h10));
    H(0, 1) = h01 + (d01 + (d00 * h01 + d01 * h11));
    H(1, 0) = h10 + (d10 + (d10 * h00 + d11 * h10));
    H(1, 1) = h11 + (d11 + (d10 * h01 + d11 * h11));
}

template <int Dim, bool Flip>
float g2p(ParticleSet& ps, const Grid& grid, const TransferParams& params) {
    const float movedBound = movedSpeedSquaredBound();
    const float invDx = 1.f / ps.dx;
    const float cScale = apicInverseD(invDx) * ps.dx; // C = 4/dx^2 B with offsets in grid units
    const float dt = params.dt, flip = params.flipBlend;
    const bool xpic = params.transfer == Transfer::Xpic;
    const AuxLayout layout{Flip, params.slipMaterial >= 0};
    const int auxStride = layout.channels();
    const auto velocityField = [&grid](std::size_t b) { return grid.velocity(b); };
    const auto auxField = [&grid](std::size_t b) { return grid.aux(b); };
    return std::sqrt(tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, ps.leafCount(), 1), 0.f,
        [&](const auto& r, float maxSpeedSquared) {
            constexpr int channels = g2pLanes<Flip>();
            alignas(32) float local[paddedNodes<Dim>() * channels];
            alignas(32) float upperLocal[paddedNodes<Dim>() * channels]; // the upper field's
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
                // Only the nodes that the awake particles' stencils reach.
                const NodeBox box =
                    nodeBoxOf<Dim>(ps, l, invDx, [&](std::uint32_t i) { return !ps.asleep(i); });
                if (readsLower) {
                    gatherPadded<Dim>(grid, l, box, velocityField, 3, 0, channels, local);
                    if (Flip) {
                        gatherPadded<Dim>(grid, l, box, auxField, auxStride,
                                          layout.lowerReference(), channels, local + 4);
                        toIncrement<Dim>(box, local);
                    }
                }
                if (readsUpper) {
                    gatherPadded<Dim>(grid, l, box, auxField, auxStride, layout.upperVelocity(),
                                      channels, upperLocal);
                    if (Flip) {
                        gatherPadded<Dim>(grid, l, box, auxField, auxStride,
                                          layout.upperReference(), channels, upperLocal + 4);
                        toIncrement<Dim>(box, upperLocal);
                    }
                }
                const auto localOf = [&](std::uint32_t i) {
                    return layout.twoFields && (ps.plastic[i].flags & kFlagUpperField) ? upperLocal
                                                                                       : local;
                };
                // The particle's new velocity, affine matrix, position and F; false on NaN.
                const auto update = [&](std::uint32_t i, const Vec3f& vPic, const Mat3f& B,
                                        const Vec3f& dvFlip) {
                    // XPIC: the reference is v^L - v* (xpicReference), the increment its update.
                    const Vec3f vNew = !Flip ? vPic
                                       : xpic
                                           ? dvFlip
                                           : Vec3f(flip * (ps.v[i] + dvFlip) + (1.f - flip) * vPic);
                    ps.v[i] = vNew;
                    ps.x[i] += dt * vPic;
                    // Fe <- (I + dt C) Fe, as H <- H + dt C (I + H) so that a strain increment
                    // far below float spacing at 1 is kept (ParticleSet::H).
                    if constexpr (Dim == 2)
                        updateAffinePlane(cScale * B(0, 0), cScale * B(0, 1), cScale * B(1, 0),
                                          cScale * B(1, 1), dt, ps.C[i], ps.H[i]);
                    else {
                        const Mat3f C = cScale * B;
                        ps.C[i] = C;
                        const Mat3f dtC = dt * C;
                        ps.H[i] += dtC + dtC * ps.H[i];
                    }
                    // Squared speeds: the square root's latency held each particle up (perf
                    // annotate), and it is monotone, so the flag and the maximum are those of
                    // the speeds, bit for bit (movedSpeedSquaredBound); one root at the end.
                    const float speedSquared = vNew.squaredNorm();
                    if (speedSquared > movedBound) ps.plastic[i].flags |= kFlagMoved;
                    // NaN compares false: make it win the reduction so the caller sees it.
                    maxSpeedSquared = speedSquared == speedSquared
                                          ? std::max(maxSpeedSquared, speedSquared)
                                          : std::numeric_limits<float>::quiet_NaN();
                    return maxSpeedSquared == maxSpeedSquared;
                };
                const auto single = [&](std::uint32_t i) {
                    Vec3f vPic, dvFlip;
                    Mat3f B;
                    gatherParticle<Dim, Flip>(stencilOf<Dim>(ps.x[i], invDx, ps.leaves[l]),
                                              localOf(i), vPic, B, dvFlip);
                    return update(i, vPic, B, dvFlip);
                };
                // 3D without FLIP: the awake particles two at a time (gatherParticlePair).
                constexpr bool pairs = Dim == 3 && !Flip;
                constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
                std::uint32_t pending = kNone;
                for (std::uint32_t i = ps.leafStart[l]; i < ps.leafStart[l + 1]; ++i) {
                    if (ps.asleep(i)) continue;
                    if (!pairs) {
                        if (!single(i)) return maxSpeedSquared;
                        continue;
                    }
                    if (pending == kNone) {
                        pending = i;
                        continue;
                    }
                    Vec3f vPic[2];
                    Mat3f B[2];
                    gatherParticlePair(stencilOf<3>(ps.x[pending], invDx, ps.leaves[l]),
                                       localOf(pending), stencilOf<3>(ps.x[i], invDx, ps.leaves[l]),
                                       localOf(i), vPic, B);
                    if (!update(pending, vPic[0], B[0], Vec3f::Zero()) ||
                        !update(i, vPic[1], B[1], Vec3f::Zero()))
                        return maxSpeedSquared;
                    pending = kNone;
                }
                if (pending != kNone && !single(pending)) return maxSpeedSquared;
            }
            return maxSpeedSquared;
        },
        [](float a, float b) { return (a != a || b != b) ? a + b : std::max(a, b); }));
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
                    const NodeBox box =
                        nodeBoxOf<Dim>(ps, l, invDx, [](std::uint32_t) { return true; });
                    gatherPadded<Dim>(grid, l, box, termField, 3, 0, 3, local);
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
            forEachNode<Dim>([&](int n) {
                const float m = acc[4 * n];
                float* t = term.data() + (b * kLeafNodes + n) * 3;
                float* total = sum.data() + (b * kLeafNodes + n) * 3;
                for (int c = 0; c < 3; ++c) {
                    t[c] = m > 0.f ? t[c] - acc[4 * n + 1 + c] / m : 0.f;
                    total[c] += t[c];
                }
            });
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
        constexpr int pc = packedChannels<6>();
        forEachNode<Dim>([&](int n) {
            const float* a = acc + pc * n;
            const float m = a[0];
            if (m <= 0.f) return;
            const std::size_t at = b * kLeafNodes + n;
            vf.density[at] = m / cellVolume;
            vf.velocity[at] = {a[1] / m, a[2] / m, a[3] / m};
            vf.failed[at] = std::min(1.f, a[4] / m);
            vf.eta[at] = a[5] / m;
        });
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

float movedSpeedSquaredBound() {
    static const float bound = [] {
        float s = kMovedSpeed * kMovedSpeed;
        while (std::sqrt(s) > kMovedSpeed) s = std::nextafter(s, 0.f);
        while (std::sqrt(std::nextafter(s, 1.f)) <= kMovedSpeed) s = std::nextafter(s, 1.f);
        return s;
    }();
    return bound;
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
