#include <firn/diagnostics.h>
#include <firn/svd.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <type_traits>

namespace firn {

namespace {

constexpr double kMovingSpeed = 0.1; // m/s: outputs.md front_x threshold

/// p = -tr(tau)/d and q = sqrt(3/2 s:s), s = tau + p I, over the d x d block (Gaume et al. 2019).
StressInvariants invariantsOf(const Sym3f& t, int dim) {
    const double p = -(dim == 3 ? t.xx + t.yy + t.zz : t.xx + t.yy) / dim;
    const double sxx = t.xx + p, syy = t.yy + p, szz = dim == 3 ? t.zz + p : 0.0;
    double ss = sxx * sxx + syy * syy + szz * szz + 2.0 * t.xy * t.xy;
    if (dim == 3) ss += 2.0 * (t.xz * t.xz + t.yz * t.yz);
    return {float(p), float(std::sqrt(1.5 * ss))};
}

/// Two crack times of one cell as one: for the crack's extent along x the earlier; for the bed's
/// plan, the earliest and the latest.
float combineCrackTimes(float a, float b) {
    return std::min(a, b);
}

CellCrackTimes combineCrackTimes(const CellCrackTimes& a, const CellCrackTimes& b) {
    return {std::min(a.earliest, b.earliest), std::max(a.latest, b.latest)};
}

/// Union of two sorted lists of cells with crack times each; a cell in both combines them.
template <typename Key, typename Times>
void mergeCellTimes(std::vector<Key>& cells, std::vector<Times>& times,
                    const std::vector<Key>& otherCells, const std::vector<Times>& otherTimes) {
    if (otherCells.empty()) return;
    std::vector<Key> mergedCells;
    std::vector<Times> mergedTimes;
    std::size_t a = 0, b = 0;
    while (a < cells.size() || b < otherCells.size()) {
        if (b == otherCells.size() || (a < cells.size() && cells[a] < otherCells[b])) {
            mergedCells.push_back(cells[a]), mergedTimes.push_back(times[a++]);
        } else if (a == cells.size() || otherCells[b] < cells[a]) {
            mergedCells.push_back(otherCells[b]), mergedTimes.push_back(otherTimes[b++]);
        } else {
            mergedCells.push_back(cells[a]);
            mergedTimes.push_back(combineCrackTimes(times[a++], otherTimes[b++]));
        }
    }
    cells = std::move(mergedCells);
    times = std::move(mergedTimes);
}

/// (cell, crack time) pairs to sorted unique cells, each with its particles' times combined.
template <typename Key, typename Times>
void uniqueCellTimes(std::vector<std::pair<Key, float>>& cracked, std::vector<Key>& cells,
                     std::vector<Times>& times) {
    std::sort(cracked.begin(), cracked.end());
    for (const auto& [cell, time] : cracked) {
        Times own;
        if constexpr (std::is_same_v<Times, float>)
            own = time;
        else
            own = {time, time};
        if (!cells.empty() && cells.back() == cell)
            times.back() = combineCrackTimes(times.back(), own);
        else
            cells.push_back(cell), times.push_back(own);
    }
}

void merge(FrameDiagnostics& into, const FrameDiagnostics& d) {
    into.particles += d.particles;
    into.mass += d.mass;
    into.centreOfMass += d.centreOfMass; // mass-weighted sum until the end
    into.momentum += d.momentum;
    into.kineticEnergy += d.kineticEnergy;
    into.elasticEnergy += d.elasticEnergy;
    into.gravitationalEnergy += d.gravitationalEnergy;
    into.failedFraction += d.failedFraction; // failed mass until the end
    into.slabMass += d.slabMass;
    into.slabMomentum += d.slabMomentum;
    if (d.maxSpeed > into.maxSpeed || !d.finite) into.worstPosition = d.worstPosition;
    into.maxSpeed = std::max(into.maxSpeed, d.maxSpeed);
    if (d.topY > into.topY) into.topY = d.topY, into.topX = d.topX;
    into.finite = into.finite && d.finite;
    into.hasWeakLayer = into.hasWeakLayer || d.hasWeakLayer;
    auto fmaxNan = [](double a, double b) {
        return std::isnan(a) ? b : std::isnan(b) ? a : std::max(a, b);
    };
    into.frontX = fmaxNan(into.frontX, d.frontX);
    into.intactMinX = std::fmin(into.intactMinX, d.intactMinX); // NaN (none) gives way
    into.intactMaxX = std::fmax(into.intactMaxX, d.intactMaxX);
    if (d.movedTopY > into.movedTopY || std::isnan(into.movedTopY))
        if (!std::isnan(d.movedTopY))
            into.movedTopY = d.movedTopY, into.movedTopX = d.movedTopX,
            into.movedTopZ = d.movedTopZ;
    if (d.movedFarX > into.movedFarX || std::isnan(into.movedFarX))
        if (!std::isnan(d.movedFarX)) into.movedFarX = d.movedFarX, into.movedFarY = d.movedFarY;
    mergeCellTimes(into.crackCells, into.crackCellTimes, d.crackCells, d.crackCellTimes);
    if (!d.collapseCells.empty()) {
        std::vector<std::int64_t> cells;
        std::set_union(into.collapseCells.begin(), into.collapseCells.end(),
                       d.collapseCells.begin(), d.collapseCells.end(), std::back_inserter(cells));
        into.collapseCells = std::move(cells);
    }
    mergeCellTimes(into.crackPlanCells, into.crackPlanCellTimes, d.crackPlanCells,
                   d.crackPlanCellTimes);
}

/// The extent of a crack along x: the run of cells with the most cells (the lower one on ties),
/// gaps of up to kCrackGapCells bridged; cell centres, m. NaN (left as is) without cells.
void largestRun(const std::vector<std::int64_t>& c, double dx, double& minX, double& maxX) {
    std::size_t bestBegin = 0, bestEnd = 0;
    for (std::size_t begin = 0; begin < c.size();) {
        std::size_t end = begin + 1;
        while (end < c.size() && c[end] - c[end - 1] <= kCrackGapCells + 1) ++end;
        if (end - begin > bestEnd - bestBegin) bestBegin = begin, bestEnd = end;
        begin = end;
    }
    if (bestEnd == bestBegin) return;
    minX = (double(c[bestBegin]) + 0.5) * dx;
    maxX = (double(c[bestEnd - 1]) + 0.5) * dx;
}

FrameDiagnostics leafDiagnostics(const World& world, std::size_t l) {
    const ParticleSet& ps = world.particles;
    FrameDiagnostics d;
    d.topY = -std::numeric_limits<double>::infinity();
    std::vector<std::pair<std::int64_t, float>> cracked; // (cell, crack time)
    std::vector<std::pair<std::pair<std::int64_t, std::int64_t>, float>> crackedPlan; // 3D
    for (std::uint32_t i = ps.leafStart[l]; i < ps.leafStart[l + 1]; ++i) {
        const Material& mat = world.materials[ps.material[i]];
        const double m = ps.mass[i];
        const Eigen::Vector3d x = ps.x[i].cast<double>(), v = ps.v[i].cast<double>();
        const double speed = v.norm();
        ++d.particles;
        d.mass += m;
        d.centreOfMass += m * x;
        d.momentum += m * v;
        d.kineticEnergy += 0.5 * m * v.squaredNorm();
        d.gravitationalEnergy -= m * world.gravity.cast<double>().dot(x);
        const LeftStretch ls = leftStretch(ps.deformationGradient(i), world.dim);
        Vec3f eps = Vec3f::Zero();
        for (int a = 0; a < world.dim; ++a) eps[a] = std::log(ls.sigma[a]);
        d.elasticEnergy += ps.volume0[i] * henckyEnergy(mat.lame, eps, world.dim);
        if (!std::isfinite(speed) || !x.allFinite()) {
            d.finite = false;
            d.worstPosition = x;
        } else if (speed >= d.maxSpeed) {
            d.maxSpeed = speed;
            d.worstPosition = x;
        }
        if (x[1] > d.topY) d.topY = x[1], d.topX = x[0];
        if (speed > kMovingSpeed) d.frontX = std::isnan(d.frontX) ? x[0] : std::max(d.frontX, x[0]);
        if (ps.plastic[i].flags & kFlagFailed) d.failedFraction += m;
        if (mat.slab) d.slabMass += m, d.slabMomentum += m * v;
        if (ps.plastic[i].flags & kFlagMoved) {
            if (!(x[1] <= d.movedTopY)) d.movedTopY = x[1], d.movedTopX = x[0], d.movedTopZ = x[2];
            if (!(x[0] <= d.movedFarX)) d.movedFarX = x[0], d.movedFarY = x[1];
        }
        if (mat.model == MaterialModel::WeakLayer) {
            d.hasWeakLayer = true;
            const auto cellX = std::int64_t(std::floor(x[0] / world.dx));
            if (ps.plastic[i].flags & kFlagCollapsed) d.collapseCells.push_back(cellX);
            if (!(ps.plastic[i].eta > 0.f)) {
                if (!(x[0] >= d.intactMinX)) d.intactMinX = x[0];
                if (!(x[0] <= d.intactMaxX)) d.intactMaxX = x[0];
            } else {
                const float time = ps.plastic[i].fractureTime;
                cracked.push_back({cellX, time});
                if (world.dim == 3)
                    crackedPlan.push_back(
                        {{cellX, std::int64_t(std::floor(x[2] / world.dx))}, time});
            }
        }
    }
    uniqueCellTimes(cracked, d.crackCells, d.crackCellTimes);
    std::sort(d.collapseCells.begin(), d.collapseCells.end());
    d.collapseCells.erase(std::unique(d.collapseCells.begin(), d.collapseCells.end()),
                          d.collapseCells.end());
    uniqueCellTimes(crackedPlan, d.crackPlanCells, d.crackPlanCellTimes);
    return d;
}

} // namespace

FrameDiagnostics computeDiagnostics(const World& world) {
    const ParticleSet& ps = world.particles;
    std::vector<FrameDiagnostics> perLeaf(ps.leafCount());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, ps.leafCount(), 1), [&](const auto& r) {
        for (std::size_t l = r.begin(); l != r.end(); ++l) perLeaf[l] = leafDiagnostics(world, l);
    });
    FrameDiagnostics total;
    total.topY = -std::numeric_limits<double>::infinity();
    for (const FrameDiagnostics& d : perLeaf) merge(total, d);
    total.crackCellWidth = world.dx;
    largestRun(total.crackCells, world.dx, total.crackMinX, total.crackMaxX);
    largestRun(total.collapseCells, world.dx, total.collapseMinX, total.collapseMaxX);
    if (total.mass > 0) {
        total.centreOfMass /= total.mass;
        total.failedFraction /= total.mass;
    }
    return total;
}

ParticleFrame exportParticles(const World& world) {
    const ParticleSet& ps = world.particles;
    const std::size_t n = ps.size();
    ParticleFrame f;
    f.P.resize(n), f.v.resize(n), f.material.resize(n), f.failed.resize(n);
    f.eps_v.resize(n), f.eta.resize(n), f.p.resize(n), f.q.resize(n);
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, n, 4096),
        [&](const auto& r) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) {
                f.P[i] = {ps.x[i][0], ps.x[i][1], ps.x[i][2]};
                f.v[i] = {ps.v[i][0], ps.v[i][1], ps.v[i][2]};
                f.material[i] = ps.material[i];
                f.failed[i] = (ps.plastic[i].flags & kFlagFailed) ? 1 : 0;
                f.eps_v[i] = ps.plastic[i].epsV;
                f.eta[i] = ps.plastic[i].eta;
                const StressInvariants pq = invariantsOf(ps.stress(i), world.dim);
                f.p[i] = pq.p;
                f.q[i] = pq.q;
            }
        },
        tbb::simple_partitioner());
    return f;
}

void save(ByteWriter& out, const FrameDiagnostics& d) {
    out.value(std::uint64_t(d.particles));
    for (double v : {d.mass, d.kineticEnergy, d.elasticEnergy, d.gravitationalEnergy, d.maxSpeed,
                     d.topX, d.topY, d.frontX, d.movedTopX, d.movedTopY, d.movedFarX, d.movedFarY,
                     d.crackMinX, d.crackMaxX, d.failedFraction, d.slabMass})
        out.value(v);
    for (const Eigen::Vector3d* v :
         {&d.centreOfMass, &d.momentum, &d.worstPosition, &d.slabMomentum})
        for (int a = 0; a < 3; ++a) out.value((*v)[a]);
    out.value(std::uint8_t(d.hasWeakLayer)), out.value(std::uint8_t(d.finite));
    out.array(d.crackCells);
}

void load(ByteReader& in, FrameDiagnostics& d) {
    d.particles = std::size_t(in.value<std::uint64_t>());
    for (double* v :
         {&d.mass, &d.kineticEnergy, &d.elasticEnergy, &d.gravitationalEnergy, &d.maxSpeed, &d.topX,
          &d.topY, &d.frontX, &d.movedTopX, &d.movedTopY, &d.movedFarX, &d.movedFarY, &d.crackMinX,
          &d.crackMaxX, &d.failedFraction, &d.slabMass})
        in.value(*v);
    for (Eigen::Vector3d* v : {&d.centreOfMass, &d.momentum, &d.worstPosition, &d.slabMomentum})
        for (int a = 0; a < 3; ++a) in.value((*v)[a]);
    d.hasWeakLayer = in.value<std::uint8_t>() != 0;
    d.finite = in.value<std::uint8_t>() != 0;
    in.array(d.crackCells);
}

} // namespace firn
