#include <firn/particles.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>

namespace firn {

namespace {

constexpr std::uint8_t kFar = 255; // moved more than one leaf in one step
constexpr int kDirections = 27;
constexpr std::uint8_t kStay = 13; // direction code of (0, 0, 0)

bool keyLess(const LeafKey& a, const LeafKey& b) {
    return a < b;
}

std::uint8_t directionCode(const LeafKey& from, const LeafKey& to) {
    int code = 0;
    for (int a = 0; a < 3; ++a) {
        const int d = to[a] - from[a];
        if (d < -1 || d > 1) return kFar;
        code = code * 3 + (d + 1);
    }
    return static_cast<std::uint8_t>(code);
}

LeafKey offsetKey(const LeafKey& k, int code) {
    return {k[0] + code / 9 - 1, k[1] + (code / 3) % 3 - 1, k[2] + code % 3 - 1};
}

std::size_t findLeaf(const std::vector<LeafKey>& leaves, const LeafKey& k) {
    return static_cast<std::size_t>(std::lower_bound(leaves.begin(), leaves.end(), k, keyLess) -
                                    leaves.begin());
}

} // namespace

LeafKey leafOf(const Vec3f& x, float invDx, int dim) {
    LeafKey key{0, 0, 0};
    for (int a = 0; a < dim; ++a) {
        const int base = static_cast<int>(std::floor(x[a] * invDx - 0.5f));
        key[a] = base >> kLeafLog2; // arithmetic shift: floor division for negative nodes too
    }
    return key;
}

void ParticleSet::add(const Vec3f& position, const Vec3f& velocity, float particleMass,
                      float volume, int materialIndex, const PlasticState& state) {
    x.push_back(position);
    v.push_back(velocity);
    C.push_back(Mat3f::Zero());
    H.push_back(Mat3f::Zero());
    tau.push_back(Sym3f{});
    mass.push_back(particleMass);
    volume0.push_back(volume);
    material.push_back(materialIndex);
    plastic.push_back(state);
}

void ParticleSet::reserve(std::size_t n) {
    x.reserve(n), v.reserve(n), C.reserve(n), H.reserve(n), tau.reserve(n);
    mass.reserve(n), volume0.reserve(n), material.reserve(n), plastic.reserve(n);
}

namespace {

/// Exchanges the particle arrays of two sets (leaves and scratch stay).
void swapArrays(ParticleSet& a, ParticleSet& b) {
    a.x.swap(b.x), a.v.swap(b.v), a.C.swap(b.C), a.H.swap(b.H), a.tau.swap(b.tau);
    a.mass.swap(b.mass), a.volume0.swap(b.volume0), a.material.swap(b.material);
    a.plastic.swap(b.plastic);
}

} // namespace

ParticleSet ParticleSet::extractFlagged(std::uint32_t flags) {
    ParticleSet out;
    out.dim = dim, out.dx = dx;
    std::size_t flagged = 0;
    for (const PlasticState& s : plastic) flagged += (s.flags & flags) != 0;
    leaves.clear(), leafStart.clear(), leafQuietSteps.clear(), leafSleep.clear(), leafPush.clear(),
        leafQuietVelocity.clear();
    if (flagged == 0) return out;
    if (flagged == size()) { // all of them: hand the arrays over, no copy
        swapArrays(*this, out);
        return out;
    }
    out.reserve(flagged);
    std::size_t kept = 0;
    for (std::size_t i = 0; i < size(); ++i) {
        if (plastic[i].flags & flags) {
            out.x.push_back(x[i]), out.v.push_back(v[i]), out.C.push_back(C[i]);
            out.H.push_back(H[i]), out.tau.push_back(tau[i]), out.mass.push_back(mass[i]);
            out.volume0.push_back(volume0[i]), out.material.push_back(material[i]);
            out.plastic.push_back(plastic[i]);
            continue;
        }
        x[kept] = x[i], v[kept] = v[i], C[kept] = C[i], H[kept] = H[i], tau[kept] = tau[i];
        mass[kept] = mass[i], volume0[kept] = volume0[i], material[kept] = material[i];
        plastic[kept] = plastic[i];
        ++kept;
    }
    x.resize(kept), v.resize(kept), C.resize(kept), H.resize(kept), tau.resize(kept);
    mass.resize(kept), volume0.resize(kept), material.resize(kept), plastic.resize(kept);
    return out;
}

void ParticleSet::append(ParticleSet&& other) {
    if (size() == 0) {
        swapArrays(*this, other);
    } else {
        // Fits in the capacity left by extractFlagged: no second copy of the state.
        x.insert(x.end(), other.x.begin(), other.x.end());
        v.insert(v.end(), other.v.begin(), other.v.end());
        C.insert(C.end(), other.C.begin(), other.C.end());
        H.insert(H.end(), other.H.begin(), other.H.end());
        tau.insert(tau.end(), other.tau.begin(), other.tau.end());
        mass.insert(mass.end(), other.mass.begin(), other.mass.end());
        volume0.insert(volume0.end(), other.volume0.begin(), other.volume0.end());
        material.insert(material.end(), other.material.begin(), other.material.end());
        plastic.insert(plastic.end(), other.plastic.begin(), other.plastic.end());
    }
    other = ParticleSet{};
}

namespace {

/// The stress array's bytes lent to bucketing (the stress is recomputed after it, applyPlasticity):
/// 24 a particle, of which the gather order takes the first 4 n, the direction codes the next n
/// while the order is built, then the gather's scratch 20 a particle. Nothing is allocated per
/// step for it (the order once was a member array: 4 bytes a particle more at the memory peak).
/// Accessed by memcpy: the storage holds floats.
class LentBytes {
public:
    LentBytes(std::vector<Sym3f>& tau, std::size_t n)
        : mBytes(reinterpret_cast<unsigned char*>(tau.data()))
        , mN(n) {
        static_assert(sizeof(Sym3f) == kOrderBytes + kScratchStride);
    }
    static constexpr std::size_t kOrderBytes = sizeof(std::uint32_t);
    static constexpr std::size_t kScratchStride = 20; ///< gather bytes a particle and pass
    std::uint32_t order(std::size_t k) const {
        std::uint32_t i;
        std::memcpy(&i, mBytes + kOrderBytes * k, kOrderBytes);
        return i;
    }
    void setOrder(std::size_t k, std::uint32_t i) {
        std::memcpy(mBytes + kOrderBytes * k, &i, kOrderBytes);
    }
    unsigned char* codes() { return mBytes + kOrderBytes * mN; }
    unsigned char* scratch() { return mBytes + kOrderBytes * mN; }

private:
    unsigned char* mBytes;
    std::size_t mN;
};

/// Bytes [Offset, Offset + Len) of each element of an attribute array: a piece of a gather pass.
template <std::size_t Offset, std::size_t Len, typename T> struct Slice {
    static constexpr std::size_t kLen = Len;
    static_assert(Offset + Len <= sizeof(T));
    std::vector<T>* array;
    /// Copies element `from`'s bytes to `out` and advances it.
    void read(std::size_t from, unsigned char*& out) const {
        std::memcpy(out, reinterpret_cast<const unsigned char*>(array->data() + from) + Offset,
                    Len);
        out += Len;
    }
    /// Copies `in`'s bytes to element `to` and advances it.
    void write(std::size_t to, const unsigned char*& in) const {
        std::memcpy(reinterpret_cast<unsigned char*>(array->data() + to) + Offset, in, Len);
        in += Len;
    }
};
template <std::size_t Offset, std::size_t Len, typename T>
Slice<Offset, Len, T> slice(std::vector<T>& a) {
    return {&a};
}

/// Gathers a[k] = a[order[k]] for k in `range` (order is the identity outside it) for every
/// slice at once, in parallel through the lent scratch. The slice sizes are compile-time
/// constants, so each copy is a few moves, not a call to memcpy; and attributes share passes
/// (one per 20 bytes of a particle's state instead of one per attribute): bucketing runs every
/// step, and each pass is two parallel loops with a join between them.
template <typename... Slices>
void gatherPass(LentBytes& lent, const tbb::blocked_range<std::size_t>& range, Slices... slices) {
    constexpr std::size_t width = (Slices::kLen + ...);
    static_assert(width <= LentBytes::kScratchStride);
    unsigned char* scratch = lent.scratch();
    const tbb::blocked_range<std::size_t> chunks(range.begin(), range.end(), 4096);
    tbb::parallel_for(chunks, [&](const auto& r) {
        for (std::size_t k = r.begin(); k != r.end(); ++k) {
            unsigned char* out = scratch + k * width;
            (slices.read(lent.order(k), out), ...);
        }
    });
    tbb::parallel_for(chunks, [&](const auto& r) {
        for (std::size_t k = r.begin(); k != r.end(); ++k) {
            const unsigned char* in = scratch + k * width;
            (slices.write(k, in), ...);
        }
    });
}

/// The part of the arrays that a gather in the lent order changes: from its first to its last k
/// with order(k) != k. A few particles crossing into a neighbouring leaf move only the particles
/// between the two leaves; a body at rest, or settling, moves next to none.
tbb::blocked_range<std::size_t> movedRange(const LentBytes& lent, std::size_t n) {
    std::size_t first = 0, last = n;
    while (first < last && lent.order(first) == first) ++first;
    while (last > first && lent.order(last - 1) == last - 1) --last;
    return tbb::blocked_range<std::size_t>(first, last);
}

// Initial bucketing of unsorted particles: a stable sort by leaf key.
void sortFromScratch(const std::vector<LeafKey>& keys, LentBytes& lent,
                     std::vector<LeafKey>& leaves, std::vector<std::uint32_t>& leafStart) {
    std::vector<std::uint32_t> order(keys.size());
    std::iota(order.begin(), order.end(), 0u);
    std::stable_sort(order.begin(), order.end(),
                     [&](std::uint32_t a, std::uint32_t b) { return keys[a] < keys[b]; });
    leaves.clear();
    leafStart.clear();
    for (std::size_t k = 0; k < order.size(); ++k) {
        if (leaves.empty() || leaves.back() != keys[order[k]]) {
            leaves.push_back(keys[order[k]]);
            leafStart.push_back(static_cast<std::uint32_t>(k));
        }
    }
    leafStart.push_back(static_cast<std::uint32_t>(order.size()));
    for (std::size_t k = 0; k < order.size(); ++k) lent.setOrder(k, order[k]);
}

/// Per-leaf values of `newLeaves` from those of the same keys in `oldLeaves` (`fresh` for new
/// keys); both sorted.
template <typename T>
std::vector<T> carryByKey(const std::vector<LeafKey>& oldLeaves, const std::vector<T>& oldValues,
                          const std::vector<LeafKey>& newLeaves, const T& fresh) {
    std::vector<T> values(newLeaves.size(), fresh);
    if (oldValues.size() != oldLeaves.size()) return values;
    std::size_t o = 0;
    for (std::size_t k = 0; k < newLeaves.size(); ++k) {
        while (o < oldLeaves.size() && keyLess(oldLeaves[o], newLeaves[k])) ++o;
        if (o < oldLeaves.size() && oldLeaves[o] == newLeaves[k]) values[k] = oldValues[o];
    }
    return values;
}

} // namespace

void ParticleSet::bucketByLeaf() {
    const float invDx = 1.f / dx;
    const std::size_t n = size();
    LentBytes lent(tau, n);
    if (leaves.empty()) {
        std::vector<LeafKey> keys(n);
        for (std::size_t i = 0; i < n; ++i) keys[i] = leafOf(x[i], invDx, dim);
        sortFromScratch(keys, lent, leaves, leafStart);
        leafQuietSteps.clear();
        leafSleep.clear();
        leafPush.clear();
        leafQuietVelocity.clear();
    } else {
        // A counting sort: particles move at most one leaf per step at CFL-limited steps, so
        // each leaf sends particles to its 27 neighbours (direction codes); rare far movers are
        // placed serially. The new order is by old leaf, then old order: deterministic.
        const std::size_t nl = leafCount();
        unsigned char* code = lent.codes();
        std::vector<std::array<std::uint32_t, kDirections>> count(nl);
        std::vector<std::uint32_t> farCount(nl); // so that the serial pass skips most leaves
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nl, 1), [&](const auto& r) {
            for (std::size_t l = r.begin(); l != r.end(); ++l) {
                // Most particles stay in their leaf: their count is kept in a register, apart
                // from the histogram's chain of loads and stores on one counter.
                std::array<std::uint32_t, kDirections> counts{};
                std::uint32_t stay = 0, farHere = 0;
                const LeafKey from = leaves[l];
                for (std::uint32_t i = leafStart[l]; i < leafStart[l + 1]; ++i) {
                    const std::uint8_t c = directionCode(from, leafOf(x[i], invDx, dim));
                    code[i] = c;
                    if (c == kStay)
                        ++stay;
                    else if (c != kFar)
                        ++counts[c];
                    else
                        ++farHere;
                }
                counts[kStay] = stay;
                count[l] = counts;
                farCount[l] = farHere;
            }
        });
        bool moved = false;
        std::vector<LeafKey> newLeaves;
        std::vector<std::pair<LeafKey, std::uint32_t>> far; // (key, particle)
        for (std::size_t l = 0; l < nl; ++l) {
            for (int c = 0; c < kDirections; ++c) {
                if (count[l][c] == 0) continue;
                newLeaves.push_back(offsetKey(leaves[l], c));
                moved |= (c != kStay);
            }
            if (farCount[l] == 0) continue;
            for (std::uint32_t i = leafStart[l]; i < leafStart[l + 1]; ++i) {
                if (code[i] != kFar) continue;
                far.push_back({leafOf(x[i], invDx, dim), i});
                newLeaves.push_back(far.back().first);
                moved = true;
            }
        }
        if (!moved) return;
        std::sort(newLeaves.begin(), newLeaves.end(), keyLess);
        newLeaves.erase(std::unique(newLeaves.begin(), newLeaves.end()), newLeaves.end());

        // Destination leaf of each (old leaf, direction), and the start offsets.
        std::vector<std::array<std::uint32_t, kDirections>> dest(nl);
        std::vector<std::uint32_t> newCount(newLeaves.size(), 0);
        for (std::size_t l = 0; l < nl; ++l) {
            for (int c = 0; c < kDirections; ++c) {
                if (count[l][c] == 0) continue;
                dest[l][c] =
                    static_cast<std::uint32_t>(findLeaf(newLeaves, offsetKey(leaves[l], c)));
                newCount[dest[l][c]] += count[l][c];
            }
        }
        std::vector<std::uint32_t> farDest(far.size());
        for (std::size_t f = 0; f < far.size(); ++f) {
            farDest[f] = static_cast<std::uint32_t>(findLeaf(newLeaves, far[f].first));
            ++newCount[farDest[f]];
        }
        std::vector<std::uint32_t> newStart(newLeaves.size() + 1, 0);
        for (std::size_t k = 0; k < newLeaves.size(); ++k)
            newStart[k + 1] = newStart[k] + newCount[k];

        // Cursor per (old leaf, direction): old leaves in ascending order fill each new leaf.
        std::vector<std::uint32_t> cursor(newStart.begin(), newStart.end() - 1);
        std::vector<std::array<std::uint32_t, kDirections>> first(nl);
        std::size_t f = 0;
        for (std::size_t l = 0; l < nl; ++l) {
            for (int c = 0; c < kDirections; ++c) {
                if (count[l][c] == 0) continue;
                first[l][c] = cursor[dest[l][c]];
                cursor[dest[l][c]] += count[l][c];
            }
            for (; f < far.size() && far[f].second < leafStart[l + 1]; ++f)
                lent.setOrder(cursor[farDest[f]]++, far[f].second);
        }
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nl, 1), [&](const auto& r) {
            for (std::size_t l = r.begin(); l != r.end(); ++l) {
                auto next = first[l];
                for (std::uint32_t i = leafStart[l]; i < leafStart[l + 1]; ++i)
                    if (code[i] != kFar) lent.setOrder(next[code[i]]++, i);
            }
        });
        leafQuietSteps = carryByKey(leaves, leafQuietSteps, newLeaves, std::uint16_t(0));
        leafPush = carryByKey(leaves, leafPush, newLeaves, Vec3f(Vec3f::Zero()));
        leafQuietVelocity = carryByKey(leaves, leafQuietVelocity, newLeaves, Vec3f(Vec3f::Zero()));
        leafSleep.assign(newLeaves.size(), 0); // per-leaf state is rebuilt by the sleep pass
        leaves.swap(newLeaves);
        leafStart.swap(newStart);
    }
    // 128 bytes of state a particle in seven passes of at most 20 (the sizes are checked: an
    // attribute that grows, or a new one, needs its slices here).
    static_assert(sizeof(Vec3f) == 12 && sizeof(Mat3f) == 36 && sizeof(float) == 4 &&
                  sizeof(std::int32_t) == 4 && sizeof(PlasticState) == 20);
    const tbb::blocked_range<std::size_t> range = movedRange(lent, n);
    gatherPass(lent, range, slice<0, 12>(x), slice<0, 4>(mass), slice<0, 4>(volume0));
    gatherPass(lent, range, slice<0, 12>(v), slice<0, 4>(material));
    gatherPass(lent, range, slice<0, 20>(C));
    gatherPass(lent, range, slice<20, 16>(C));
    gatherPass(lent, range, slice<0, 20>(H));
    gatherPass(lent, range, slice<20, 16>(H));
    gatherPass(lent, range, slice<0, 20>(plastic));
}

} // namespace firn
