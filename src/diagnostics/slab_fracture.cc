// Slab fractures through the slab's thickness and the blocks the slab breaks into (Gaume et al.
// 2019, sec. 3, Figs. 3, 5, A1). Every result is computed after sorting on keys that order the
// samples completely, so it is the same for any particle order and thread count.
#include <firn/slab_fracture.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <tuple>

namespace firn {

namespace {

constexpr std::size_t kNone = std::size_t(-1);

int cellIndex(double coord, double dx) {
    return int(std::floor(coord / dx));
}

/// Union-find whose roots are the smallest index of their set, so labels do not depend on the
/// order of the joins.
class DisjointSets {
public:
    explicit DisjointSets(std::size_t n)
        : mParent(n) {
        std::iota(mParent.begin(), mParent.end(), std::size_t(0));
    }
    std::size_t find(std::size_t i) {
        while (mParent[i] != i) i = mParent[i] = mParent[mParent[i]];
        return i;
    }
    void join(std::size_t a, std::size_t b) {
        a = find(a), b = find(b);
        if (a != b) mParent[std::max(a, b)] = std::min(a, b);
    }

private:
    std::vector<std::size_t> mParent;
};

/// Position of `key` in the sorted `keys`, kNone when absent.
template <class Key> std::size_t indexOf(const std::vector<Key>& keys, const Key& key) {
    const auto it = std::lower_bound(keys.begin(), keys.end(), key);
    return it != keys.end() && *it == key ? std::size_t(it - keys.begin()) : kNone;
}

/// Fractured samples in the order they fractured; ties from the bottom up, then along the bed.
bool fracturedBefore(const SlabSample* a, const SlabSample* b) {
    return std::tie(a->fractureTime, a->height, a->bedX, a->bedZ) <
           std::tie(b->fractureTime, b->height, b->bedX, b->bedZ);
}

using BinKey = std::array<int, 2>; // (iz, ix): sorted keys run along x within a row of z

/// Whether the samples of a window of bins have fractured through the slab's thickness, and
/// when (see slab_fracture.h).
bool throughWindow(const std::vector<const SlabSample*>& window, double dx, ThroughBin& bin) {
    std::vector<int> rows;
    std::vector<const SlabSample*> fractured;
    double lo = window.front()->height, hi = lo;
    for (const SlabSample* s : window) {
        rows.push_back(cellIndex(s->height, dx));
        lo = std::min(lo, double(s->height)), hi = std::max(hi, double(s->height));
        if (s->fractured) fractured.push_back(s);
    }
    std::sort(rows.begin(), rows.end());
    rows.erase(std::unique(rows.begin(), rows.end()), rows.end());
    // the rounding guard keeps 0.8 * 5 at 4 rows
    const std::size_t needed =
        std::max<std::size_t>(1, std::size_t(std::ceil(kThroughShare * rows.size() - 1e-9)));
    if (fractured.size() < needed) return false;
    std::sort(fractured.begin(), fractured.end(), fracturedBefore);
    std::vector<char> filled(rows.size(), 0);
    std::size_t count = 0;
    for (const SlabSample* s : fractured) {
        const std::size_t r = indexOf(rows, cellIndex(s->height, dx));
        if (filled[r]) continue;
        filled[r] = 1;
        if (++count < needed) continue;
        const SlabSample& first = *fractured.front();
        bin.time = s->fractureTime;
        bin.startDepthFraction = hi > lo ? (first.height - lo) / (hi - lo) : 0.0;
        bin.startY = first.position[1];
        bin.startTime = first.fractureTime;
        return true;
    }
    return false;
}

} // namespace

std::vector<SlabSample> slabSamples(const World& world) {
    const ParticleSet& ps = world.particles;
    std::vector<std::uint32_t> slab;
    for (std::size_t i = 0; i < ps.size(); ++i)
        if (world.materials[ps.material[i]].slab) slab.push_back(i);
    std::vector<SlabSample> samples(slab.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, slab.size(), 4096), [&](const auto& r) {
        for (std::size_t k = r.begin(); k != r.end(); ++k) {
            const std::uint32_t i = slab[k];
            SlabSample& s = samples[k];
            s.position = ps.x[i];
            s.mass = ps.mass[i];
            s.fractured = ps.plastic[i].flags & kFlagSlabFractured;
            s.fractureTime = ps.plastic[i].fractureTime;
            const Collider* bed = nullptr;
            float distance = 0.f;
            for (const Collider& c : world.colliders) {
                const float d = c.signedDistance(s.position);
                if (!bed || d < distance) bed = &c, distance = d;
            }
            const Vec3f foot =
                bed ? Vec3f(s.position - distance * bed->normal(s.position)) : s.position;
            s.height = bed ? distance : s.position[1];
            s.bedX = foot[0];
            s.bedZ = world.dim == 3 ? foot[2] : 0.f;
        }
    });
    return samples;
}

std::vector<ThroughBin> findThroughBins(const std::vector<SlabSample>& samples, double dx,
                                        int dim) {
    std::vector<std::pair<BinKey, const SlabSample*>> entries;
    entries.reserve(samples.size());
    for (const SlabSample& s : samples)
        entries.push_back({{dim == 3 ? cellIndex(s.bedZ, dx) : 0, cellIndex(s.bedX, dx)}, &s});
    std::sort(entries.begin(), entries.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    std::vector<BinKey> keys;
    std::vector<std::size_t> start; // entries of bin b: [start[b], start[b + 1])
    for (std::size_t e = 0; e < entries.size(); ++e) {
        if (keys.empty() || keys.back() != entries[e].first) {
            keys.push_back(entries[e].first);
            start.push_back(e);
        }
    }
    start.push_back(entries.size());

    std::vector<ThroughBin> through;
    std::vector<const SlabSample*> window;
    for (std::size_t b = 0; b < keys.size(); ++b) {
        const bool anyFractured =
            std::any_of(entries.begin() + start[b], entries.begin() + start[b + 1],
                        [](const auto& e) { return e.second->fractured; });
        if (!anyFractured) continue;
        // the bin and its neighbours along x (adjacent in the sorted keys when present)
        const auto [iz, ix] = keys[b];
        const std::size_t lo = b > 0 && keys[b - 1] == BinKey{iz, ix - 1} ? b - 1 : b;
        const std::size_t hi =
            b + 1 < keys.size() && keys[b + 1] == BinKey{iz, ix + 1} ? b + 2 : b + 1;
        window.clear();
        for (std::size_t e = start[lo]; e < start[hi]; ++e) window.push_back(entries[e].second);
        ThroughBin bin;
        bin.ix = ix, bin.iz = iz;
        if (throughWindow(window, dx, bin)) through.push_back(bin);
    }
    return through;
}

SlabBlocks findSlabBlocks(const std::vector<SlabSample>& samples, double dx, int dim) {
    using Cell = std::array<int, 3>;
    std::vector<std::pair<Cell, float>> intact;
    for (const SlabSample& s : samples) {
        if (s.fractured) continue;
        const Cell c{cellIndex(s.position[0], dx), cellIndex(s.position[1], dx),
                     dim == 3 ? cellIndex(s.position[2], dx) : 0};
        intact.push_back({c, s.mass});
    }
    std::sort(intact.begin(), intact.end()); // masses summed in this order: order-independent
    std::vector<Cell> cells;
    std::vector<double> cellMass;
    for (const auto& [c, m] : intact) {
        if (cells.empty() || cells.back() != c) cells.push_back(c), cellMass.push_back(0.0);
        cellMass.back() += m;
    }
    DisjointSets blocks(cells.size());
    for (std::size_t c = 0; c < cells.size(); ++c) {
        for (int axis = 0; axis < dim; ++axis) {
            Cell next = cells[c];
            ++next[axis];
            const std::size_t n = indexOf(cells, next);
            if (n != kNone) blocks.join(c, n);
        }
    }
    std::vector<double> blockMass(cells.size(), 0.0);
    for (std::size_t c = 0; c < cells.size(); ++c) blockMass[blocks.find(c)] += cellMass[c];
    std::vector<double> masses;
    for (std::size_t c = 0; c < cells.size(); ++c)
        if (blocks.find(c) == c) masses.push_back(blockMass[c]);
    SlabBlocks result;
    result.count = masses.size();
    if (masses.empty()) return result;
    std::sort(masses.begin(), masses.end());
    const std::size_t n = masses.size();
    result.largestMass = masses.back();
    result.medianMass = n % 2 ? masses[n / 2] : 0.5 * (masses[n / 2 - 1] + masses[n / 2]);
    return result;
}

void SlabFractureTracker::update(const std::vector<SlabSample>& samples, double dx, int dim,
                                 double time, const CrackTracker& crack) {
    const std::vector<ThroughBin> through = findThroughBins(samples, dx, dim);
    std::vector<BinKey> keys;
    for (const ThroughBin& b : through) keys.push_back({b.iz, b.ix});
    DisjointSets runs(through.size());
    for (std::size_t b = 0; b < through.size(); ++b) {
        for (const BinKey& next :
             {BinKey{keys[b][0], keys[b][1] + 1}, BinKey{keys[b][0] + 1, keys[b][1]}}) {
            const std::size_t n = indexOf(keys, next);
            if (n != kNone) runs.join(b, n);
        }
    }
    // Per run: whether it was through before, and its earliest bin (bins are in (iz, ix) order).
    std::vector<char> seenBefore(through.size(), 0);
    std::vector<std::size_t> earliest(through.size(), kNone);
    for (std::size_t b = 0; b < through.size(); ++b) {
        const std::size_t r = runs.find(b);
        if (through[b].time <= mPreviousTime) seenBefore[r] = 1;
        if (earliest[r] == kNone || through[b].time < through[earliest[r]].time) earliest[r] = b;
    }
    std::vector<SlabFracture> found;
    for (std::size_t r = 0; r < through.size(); ++r) {
        if (runs.find(r) != r || seenBefore[r]) continue;
        const ThroughBin& bin = through[earliest[r]];
        SlabFracture f;
        f.x = (bin.ix + 0.5) * dx;
        f.y = bin.startY;
        f.z = dim == 3 ? (bin.iz + 0.5) * dx : 0.0;
        f.time = bin.time;
        f.startDepthFraction = bin.startDepthFraction;
        const double behind = crack.distanceBehind(f.x, f.time);
        if (std::isfinite(behind)) f.distanceBehindCrackTip = behind;
        f.startTime = bin.startTime;
        const double behindAtStart = crack.distanceBehind(f.x, f.startTime);
        if (std::isfinite(behindAtStart)) f.distanceBehindCrackTipAtStart = behindAtStart;
        found.push_back(f);
    }
    std::sort(found.begin(), found.end(), [](const SlabFracture& a, const SlabFracture& b) {
        return std::tie(a.time, a.z, a.x) < std::tie(b.time, b.z, b.x);
    });
    mFractures.insert(mFractures.end(), found.begin(), found.end());
    // Fracture times are floats (PlasticState): compare with the frame time rounded the same
    // way, so that a bin through at this frame is never new again at the next.
    mPreviousTime = float(time);

    mBlocks = findSlabBlocks(samples, dx, dim);
    mMaxBlocks = std::max(mMaxBlocks, mBlocks.count);
    double mass = 0.0, fracturedMass = 0.0;
    for (const SlabSample& s : samples) {
        mass += s.mass;
        if (s.fractured) fracturedMass += s.mass;
    }
    mFracturedFraction = mass > 0.0 ? fracturedMass / mass : std::nan("");
}

void SlabFractureTracker::save(ByteWriter& out) const {
    out.value(mPreviousTime);
    out.array(mFractures);
    out.value(mBlocks);
    out.value(std::uint64_t(mMaxBlocks));
    out.value(mFracturedFraction);
}

void SlabFractureTracker::load(ByteReader& in) {
    in.value(mPreviousTime);
    in.array(mFractures);
    in.value(mBlocks);
    mMaxBlocks = std::size_t(in.value<std::uint64_t>());
    in.value(mFracturedFraction);
}

} // namespace firn
