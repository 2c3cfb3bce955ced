// Scene -> world: materials, colliders and particle seeding from bodies.
#include <firn/gis.h>
#include <firn/slip_contact.h>
#include <firn/solver.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <functional>
#include <iomanip>
#include <limits>
#include <sstream>
#include <string>
#include <unordered_set>
#include <utility>

namespace firn {

namespace {

/// SplitMix64 (Steele et al. 2014): a counter-based generator, so that every seed position
/// depends only on (seed, body, cell, sample) and not on the order of seeding.
std::uint64_t splitMix(std::uint64_t z) {
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

float uniform01(std::uint64_t& state) {
    state = splitMix(state);
    return float(state >> 40) * (1.f / 16777216.f);
}

Vec3f toVec3f(const Vec3d& v) {
    return Vec3f(float(v[0]), float(v[1]), float(v[2]));
}

/// Smallest signed distance to any terrain: the height above the ground, measured normal to it.
float groundDistance(const std::vector<Collider>& colliders, const Vec3f& p) {
    float d = std::numeric_limits<float>::max();
    for (const Collider& c : colliders) d = std::min(d, c.signedDistance(p));
    return d;
}

float groundHeight(const std::vector<Collider>& colliders, float x, float z) {
    float h = -std::numeric_limits<float>::infinity();
    for (const Collider& c : colliders) h = std::max(h, c.heightAt(x, z));
    return h;
}

float standardNormal(std::uint64_t& state) {
    // Box-Muller on two uniforms in (0, 1].
    const double u1 = (double(splitMix(state) >> 11) + 1.0) * 0x1.0p-53;
    state = splitMix(state);
    const double u2 = double(state >> 11) * 0x1.0p-53;
    return float(std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2));
}

/// Thickness of a layer body at (x, z): t0 (1 + std f(x, z)), f a Gaussian random field of unit
/// variance with correlation exp(-r^2 / (2 l^2)), built from random Fourier modes (Shinozuka and
/// Deodatis 1991): f = sqrt(2/N) sum cos(k_i . (x, z) + phi_i), k_i ~ N(0, 1/l^2) per axis.
/// Clamped at 5 % of t0 so that a layer never vanishes. Gaume et al. 2019 use ~25 % and 10 m.
/// A polygon body's t0 is its release area's thickness at (x, z), 0 outside every area; a layer
/// with a thickness_profile takes t0 from the profile at x.
struct ThicknessField {
    static constexpr int kModes = 64;
    double t0 = 0.0, std = 0.0; ///< t0: the largest thickness of a profile or of a polygon's areas
    std::vector<std::array<double, 3>> modes;   // kx, kz, phase
    std::vector<ReleaseArea> areas;             // polygon bodies
    std::vector<std::array<double, 2>> profile; // a layer's thickness_profile

    static ThicknessField of(const BodyDesc& body, std::uint64_t seed, std::size_t index, int dim) {
        ThicknessField f;
        f.t0 = body.thickness; // a profile's largest thickness (the parser sets it)
        f.profile = body.thicknessProfile;
        if (body.shape == BodyShape::Polygon) {
            f.areas = readReleaseAreas(body);
            f.t0 = 0.0;
            for (const ReleaseArea& a : f.areas) f.t0 = std::max(f.t0, a.thickness);
        }
        f.std = body.thicknessNoise.std;
        if (f.std <= 0.0) return f;
        std::uint64_t state = splitMix(seed * 0x51ed27ull + index + 0x1234567ull);
        const double k = 1.0 / body.thicknessNoise.correlationLength;
        for (int m = 0; m < kModes; ++m) {
            const double kx = k * standardNormal(state);
            const double kz = dim == 3 ? k * standardNormal(state) : 0.0;
            f.modes.push_back({kx, kz, 2.0 * M_PI * uniform01(state)});
        }
        return f;
    }
    /// The thickness without noise at (x, z).
    double baseAt(double x, double z) const {
        if (!profile.empty()) return profileAt(x);
        if (areas.empty()) return t0;
        for (const ReleaseArea& a : areas)
            if (a.contains(x, z)) return a.thickness;
        return 0.0;
    }
    /// The thickness profile at x: linear between its points, constant past its ends.
    double profileAt(double x) const {
        if (x <= profile.front()[0]) return profile.front()[1];
        if (x >= profile.back()[0]) return profile.back()[1];
        const auto after = std::upper_bound(profile.begin(), profile.end(), x,
                                            [](double v, const auto& p) { return v < p[0]; });
        const auto& [xa, ta] = *(after - 1);
        const auto& [xb, tb] = *after;
        return ta + (tb - ta) * (x - xa) / (xb - xa);
    }
    double at(double x, double z) const {
        const double base = baseAt(x, z);
        if (modes.empty() || base == 0.0) return base;
        double sum = 0.0;
        for (const auto& m : modes) sum += std::cos(m[0] * x + m[1] * z + m[2]);
        const double f = std::sqrt(2.0 / kModes) * sum;
        return base * std::max(0.05, 1.0 + std * f);
    }
    /// No point is thicker: |f| <= sqrt(2/N) N = sqrt(2N), and the base is at most t0.
    double bound() const { return t0 * (1.0 + std * std::sqrt(2.0 * kModes)); }
};

/// The layer bodies from `body` down to the ground: body, the one it sits on, ...
std::vector<std::size_t> layerChain(const SceneDesc& scene, std::size_t body) {
    std::vector<std::size_t> chain{body};
    while (scene.bodies[chain.back()].onTopOf != "ground") {
        const std::string& below = scene.bodies[chain.back()].onTopOf;
        auto it = std::find_if(scene.bodies.begin(), scene.bodies.end(),
                               [&](const BodyDesc& o) { return o.name == below; });
        if (it == scene.bodies.end()) break; // the parser resolved names; be safe anyway
        chain.push_back(std::size_t(it - scene.bodies.begin()));
    }
    return chain;
}

/// Every vertex of a polygon body's release areas must lie over the terrain's extent.
void checkAreasOnTerrain(const BodyDesc& body, const std::vector<ReleaseArea>& areas,
                         const std::vector<Collider>& colliders) {
    for (const ReleaseArea& a : areas)
        for (const auto& ring : a.rings)
            for (const auto& p : ring) {
                bool covered = false;
                for (const Collider& c : colliders) covered = covered || c.covers(p[0], p[1]);
                if (covered) continue;
                std::ostringstream where; // in the file's coordinates
                where << std::setprecision(10) << "(" << p[0] + body.footprintOrigin[0] << ", "
                      << p[1] + body.footprintOrigin[2] << ")";
                throw SceneError(body.loc, "body: file",
                                 body.footprintFile + ": release area " + a.label +
                                     " reaches outside the DEM: its vertex at " + where.str() +
                                     " has no terrain under it");
            }
}

struct SeedRegion {
    Vec3f lo, hi; ///< bounding box, m
    std::function<bool(const Vec3f&)> inside;
};

SeedRegion regionOf(const SceneDesc& scene, std::size_t bodyIndex,
                    const std::vector<Collider>& colliders,
                    const std::vector<ThicknessField>& fields) {
    const BodyDesc& body = scene.bodies[bodyIndex];
    const int dim = scene.simulation.dimension;
    SeedRegion r;
    if (body.shape == BodyShape::Box) {
        const Vec3f lo = toVec3f(body.min), hi = toVec3f(body.max);
        r.lo = lo, r.hi = hi;
        r.inside = [lo, hi, dim](const Vec3f& p) {
            for (int a = 0; a < dim; ++a)
                if (p[a] < lo[a] || p[a] >= hi[a]) return false;
            return true;
        };
    } else if (body.shape == BodyShape::Sphere) {
        const Vec3f c = toVec3f(body.center);
        const float rad = float(body.radius);
        r.lo = c - Vec3f::Constant(rad), r.hi = c + Vec3f::Constant(rad);
        r.inside = [c, rad](const Vec3f& p) { return (p - c).squaredNorm() < rad * rad; };
    } else {
        if (colliders.empty())
            throw SceneError(body.loc, "body: shape",
                             "a \"layer\" body needs a [[terrain]] to lie on");
        const std::vector<std::size_t> chain = layerChain(scene, bodyIndex);
        double maxStack = 0.0; // the thickest the stack can get, for the bounding box
        for (std::size_t b : chain) maxStack += fields[b].t0 * (1.0 + 5.0 * fields[b].std);
        float x0 = float(body.xRange[0]), x1 = float(body.xRange[1]);
        float z0 = dim == 3 ? float(body.zRange[0]) : 0.f;
        float z1 = dim == 3 ? float(body.zRange[1]) : 0.f;
        if (body.shape == BodyShape::Polygon) {
            const std::vector<ReleaseArea>& areas = fields[bodyIndex].areas;
            checkAreasOnTerrain(body, areas, colliders);
            x0 = z0 = std::numeric_limits<float>::max();
            x1 = z1 = -x0;
            for (const ReleaseArea& a : areas) {
                x0 = std::min(x0, float(a.xMin)), x1 = std::max(x1, float(a.xMax));
                z0 = std::min(z0, float(a.zMin)), z1 = std::max(z1, float(a.zMax));
            }
        }
        float hLo = std::numeric_limits<float>::max(), hHi = -hLo;
        const int nz = dim == 3 ? 32 : 0;
        for (int s = 0; s <= 256; ++s)
            for (int t = 0; t <= nz; ++t) {
                const float h = groundHeight(colliders, x0 + (x1 - x0) * s / 256.f,
                                             nz ? z0 + (z1 - z0) * t / float(nz) : z0);
                hLo = std::min(hLo, h), hHi = std::max(hHi, h);
            }
        // Normal thickness on slopes up to ~75 degrees fits in 4 times the vertical span.
        r.lo = Vec3f(x0, hLo - float(maxStack), z0);
        r.hi = Vec3f(x1, hHi + 4.f * float(maxStack), z1);
        double belowBound = 0.0; // the thickest the layers below can be anywhere
        for (std::size_t k = 1; k < chain.size(); ++k) belowBound += fields[chain[k]].bound();
        const double ownBound = fields[chain[0]].bound();
        // The ground distance first: most of the box is far above the layer, and the thickness
        // noise (64 cosines a field) is only needed where the bounds cannot decide.
        r.inside = [&colliders, &fields, chain, x0, x1, z0, z1, dim, belowBound,
                    ownBound](const Vec3f& p) {
            if (p[0] < x0 || p[0] >= x1) return false;
            if (dim == 3 && (p[2] < z0 || p[2] >= z1)) return false;
            const float reach = float(belowBound + ownBound);
            if (std::all_of(colliders.begin(), colliders.end(),
                            [&](const Collider& c) { return c.clearOf(p, reach); }))
                return false; // far above every profile: no segment search
            const double d = groundDistance(colliders, p);
            if (d < 0.0 || d >= belowBound + ownBound) return false;
            double base = 0.0; // the layers below, each with its thickness here
            for (std::size_t k = 1; k < chain.size(); ++k) base += fields[chain[k]].at(p[0], p[2]);
            if (d < base || d >= base + ownBound) return false;
            const double own = fields[chain[0]].at(p[0], p[2]);
            if (own <= 0.0) return false; // outside a polygon body's areas
            return d < base + own;
        };
    }
    if (dim == 2) r.lo[2] = r.hi[2] = 0.f;
    return r;
}

/// Thickness fields of every body (a layer's noise; plain t0 otherwise).
std::vector<ThicknessField> thicknessFields(const SceneDesc& scene) {
    std::vector<ThicknessField> fields;
    for (std::size_t bi = 0; bi < scene.bodies.size(); ++bi)
        fields.push_back(ThicknessField::of(scene.bodies[bi], scene.simulation.seed, bi,
                                            scene.simulation.dimension));
    return fields;
}

/// The saw cut of `body` that p lies in, or nullptr.
const CutDesc* cutAt(const SceneDesc& scene, const BodyDesc& body, const Vec3f& p) {
    for (const CutDesc& cut : scene.cuts)
        if (!body.name.empty() && cut.layer == body.name && p[0] >= cut.fromX &&
            p[0] < cut.fromX + cut.length)
            return &cut;
    return nullptr;
}

/// Visits every seed position of every body, in body order: emit(position, body index, in an
/// instant saw cut). particles_per_cell per cell of the body's bounding box, stratified on a k^d
/// sub-lattice when particles_per_cell = k^d (jittered by `jitter` of a sub-cell), uniformly
/// random in the cell otherwise; seeds inside an earlier body or a quasi-static cut are skipped.
template <typename Emit>
void forEachSeed(const SceneDesc& scene, const std::vector<Collider>& colliders, Emit&& emit) {
    const int dim = scene.simulation.dimension;
    const int ppc = scene.grid.particlesPerCell;
    const double dx = scene.grid.dx;
    const int k = int(std::lround(std::pow(double(ppc), 1.0 / dim)));
    const bool lattice = int(std::lround(std::pow(double(k), dim))) == ppc;
    const float jitter = float(scene.grid.jitter);

    const std::vector<ThicknessField> fields = thicknessFields(scene);
    std::vector<SeedRegion> regions;
    for (std::size_t bi = 0; bi < scene.bodies.size(); ++bi) {
        const BodyDesc& body = scene.bodies[bi];
        regions.push_back(regionOf(scene, bi, colliders, fields));
        const SeedRegion& region = regions.back();
        std::array<long, 3> c0{0, 0, 0}, c1{0, 0, 0};
        for (int a = 0; a < dim; ++a) {
            c0[a] = long(std::floor(region.lo[a] / dx));
            c1[a] = long(std::ceil(region.hi[a] / dx));
        }
        // Each cell draws from its own random stream, so the columns of cells along x are
        // seeded in parallel and emitted in order: the same particles for any thread count.
        struct Seed {
            Vec3f p;
            bool inCut;
        };
        std::vector<std::vector<Seed>> columns(std::size_t(std::max(0l, c1[0] - c0[0])));
        tbb::parallel_for(tbb::blocked_range<long>(c0[0], c1[0]), [&](const auto& range) {
            for (long cx = range.begin(); cx < range.end(); ++cx) {
                std::vector<Seed>& out = columns[std::size_t(cx - c0[0])];
                for (long cy = c0[1]; cy < c1[1]; ++cy)
                    for (long cz = c0[2]; cz < std::max(c1[2], c0[2] + 1); ++cz) {
                        std::uint64_t state = splitMix(scene.simulation.seed * 0x9e37ull + bi);
                        state = splitMix(state ^ std::uint64_t(cx) * 0x100000001b3ull);
                        state = splitMix(state ^ std::uint64_t(cy) * 0x1000193ull);
                        state = splitMix(state ^ std::uint64_t(cz));
                        for (int s = 0; s < ppc; ++s) {
                            const int sub[3] = {s % k, (s / k) % k, s / (k * k)};
                            Vec3f p = Vec3f::Zero();
                            const long cell[3] = {cx, cy, cz};
                            for (int a = 0; a < dim; ++a) {
                                const float u = uniform01(state);
                                const float f =
                                    lattice ? (sub[a] + 0.5f + jitter * (u - 0.5f)) / k : u;
                                p[a] = float((double(cell[a]) + f) * dx);
                            }
                            if (!region.inside(p)) continue;
                            bool taken = false;
                            for (std::size_t e = 0; e + 1 < regions.size() && !taken; ++e)
                                taken = regions[e].inside(p);
                            if (taken) continue;
                            const CutDesc* cut = cutAt(scene, body, p);
                            // A quasi-static saw cuts before the snowpack settles: no seed there.
                            if (cut && cut->saw == Saw::QuasiStatic) continue;
                            out.push_back({p, cut != nullptr});
                        }
                    }
            }
        });
        for (const std::vector<Seed>& column : columns)
            for (const Seed& seed : column) emit(seed.p, bi, seed.inCut);
    }
}

/// The bodies that rest on the terrain, directly or through other resting bodies: seeded at
/// rest with a particle within one cell of a collider's surface, or of a particle of a resting
/// body (the grid couples particles that close). The others, seeded moving or in the air (a
/// block dropped on the ground, a snowman falling on the slab), would only fall or fly while
/// the rest settles: they wait outside the settling stage and join at t = 0 as seeded.
std::vector<bool> restingBodies(const SceneDesc& scene, const World& world,
                                const std::vector<std::uint32_t>& bodyOf) {
    const std::size_t bodies = scene.bodies.size();
    const int dim = world.dim;
    const float dx = world.dx;
    auto cellOf = [&](const Vec3f& p) {
        return std::array<std::int64_t, 3>{std::int64_t(std::floor(p[0] / dx)),
                                           std::int64_t(std::floor(p[1] / dx)),
                                           dim == 3 ? std::int64_t(std::floor(p[2] / dx)) : 0};
    };
    auto key = [](std::int64_t i, std::int64_t j, std::int64_t k) {
        return ((i & 0x1fffff) << 42) | ((j & 0x1fffff) << 21) | (k & 0x1fffff);
    };
    std::vector<bool> resting(bodies, false), moving(bodies, false);
    std::vector<std::vector<std::array<std::int64_t, 3>>> cells(bodies); // occupied, per body
    std::vector<std::unordered_set<std::int64_t>> seen(bodies);
    for (std::size_t b = 0; b < bodies; ++b)
        moving[b] = scene.bodies[b].velocity != Vec3d{0.0, 0.0, 0.0};
    const ParticleSet& ps = world.particles;
    for (std::size_t i = 0; i < ps.size(); ++i) {
        const std::uint32_t b = bodyOf[i];
        const auto c = cellOf(ps.x[i]);
        if (seen[b].insert(key(c[0], c[1], c[2])).second) cells[b].push_back(c);
        if (!moving[b] && !resting[b] && groundDistance(world.colliders, ps.x[i]) < dx)
            resting[b] = true;
    }
    // Grow the resting set through touching bodies: one set of the resting bodies' cells.
    std::unordered_set<std::int64_t> restingCells;
    for (std::size_t b = 0; b < bodies; ++b)
        if (resting[b])
            for (const auto& c : cells[b]) restingCells.insert(key(c[0], c[1], c[2]));
    const int nz = dim == 3 ? 1 : 0;
    auto touchesResting = [&](const std::array<std::int64_t, 3>& c) {
        for (int ox = -1; ox <= 1; ++ox)
            for (int oy = -1; oy <= 1; ++oy)
                for (int oz = -nz; oz <= nz; ++oz)
                    if (restingCells.count(key(c[0] + ox, c[1] + oy, c[2] + oz))) return true;
        return false;
    };
    for (bool grew = true; grew;) {
        grew = false;
        for (std::size_t b = 0; b < bodies; ++b) {
            if (resting[b] || moving[b]) continue;
            for (const auto& c : cells[b])
                if (touchesResting(c)) {
                    resting[b] = grew = true;
                    break;
                }
            if (resting[b])
                for (const auto& c : cells[b]) restingCells.insert(key(c[0], c[1], c[2]));
        }
    }
    return resting;
}

/// Material::slab: the snow materials of layers on a weak layer; all snow without a weak layer.
void markSlabMaterials(const SceneDesc& scene, std::vector<Material>& materials) {
    auto isWeakLayerBody = [&](const std::string& name) {
        for (const BodyDesc& b : scene.bodies)
            if (!name.empty() && b.name == name)
                return materials[std::size_t(b.materialIndex)].model == MaterialModel::WeakLayer;
        return false;
    };
    bool anyWeakLayer = false;
    for (const BodyDesc& b : scene.bodies)
        anyWeakLayer = anyWeakLayer ||
                       materials[std::size_t(b.materialIndex)].model == MaterialModel::WeakLayer;
    for (const BodyDesc& b : scene.bodies) {
        Material& m = materials[std::size_t(b.materialIndex)];
        if (m.model != MaterialModel::Snow) continue;
        if (!anyWeakLayer || (isLayerShape(b.shape) && isWeakLayerBody(b.onTopOf))) m.slab = true;
    }
}

/// "body 2" or "body \"slab\"", as scene messages name bodies.
std::string bodyLabel(const SceneDesc& scene, std::size_t b) {
    const std::string& name = scene.bodies[b].name;
    return "body " + (name.empty() ? std::to_string(b + 1) : "\"" + name + "\"");
}

/// A body that seeds nothing, or only particles inside the terrain (which the ground would
/// throw out at the first step), is a scene error: the user meant something else.
void checkEveryBodySeeded(const SceneDesc& scene, const World& world,
                          const std::vector<std::uint32_t>& bodyOf) {
    const std::size_t bodies = scene.bodies.size();
    std::vector<std::size_t> seeded(bodies, 0);
    std::vector<bool> aboveGround(bodies, world.colliders.empty());
    const ParticleSet& ps = world.particles;
    for (std::size_t i = 0; i < ps.size(); ++i) {
        const std::uint32_t b = bodyOf[i];
        ++seeded[b];
        if (!aboveGround[b]) aboveGround[b] = groundDistance(world.colliders, ps.x[i]) >= 0.f;
    }
    std::ostringstream dx;
    dx << scene.grid.dx;
    for (std::size_t b = 0; b < bodies; ++b) {
        const BodyDesc& body = scene.bodies[b];
        if (seeded[b] == 0)
            throw SceneError(body.loc, bodyLabel(scene, b),
                             "seeds no particles at dx = " + dx.str() +
                                 " m: it lies inside earlier bodies, or is smaller than a cell");
        if (!aboveGround[b])
            throw SceneError(body.loc, bodyLabel(scene, b),
                             "lies entirely inside the terrain: all its " +
                                 std::to_string(seeded[b]) + " particles are below the ground");
    }
}

/// Seeds the bodies in two passes (count, then fill) so the particle arrays are allocated once
/// at their final size: growing them would transiently need up to twice the memory.
void seedBodies(const SceneDesc& scene, World& world) {
    std::size_t count = 0;
    forEachSeed(scene, world.colliders, [&](const Vec3f&, std::size_t, bool) { ++count; });
    world.particles.reserve(count);
    world.particlesPerBody.assign(scene.bodies.size(), 0);
    const float volume =
        float(std::pow(scene.grid.dx, scene.simulation.dimension) / scene.grid.particlesPerCell);
    std::vector<std::uint32_t> bodyOf;
    bodyOf.reserve(count);
    forEachSeed(scene, world.colliders, [&](const Vec3f& p, std::size_t bi, bool inCut) {
        const BodyDesc& body = scene.bodies[bi];
        const Material& mat = world.materials[body.materialIndex];
        PlasticState state = mat.initialState();
        if (inCut) state.flags |= kFlagInCut;
        world.particles.add(p, toVec3f(body.velocity), mat.density * volume, volume,
                            body.materialIndex, state);
        bodyOf.push_back(std::uint32_t(bi));
        if (!inCut) ++world.particlesPerBody[bi];
    });
    checkEveryBodySeeded(scene, world, bodyOf);
    const std::vector<bool> resting = restingBodies(scene, world, bodyOf);
    for (std::size_t i = 0; i < bodyOf.size(); ++i) {
        const BodyDesc& body = scene.bodies[bodyOf[i]];
        if (!resting[bodyOf[i]]) world.particles.plastic[i].flags |= kFlagOutsideSettling;
        if (!body.slidesOn.empty()) world.particles.plastic[i].flags |= kFlagUpperField;
    }
}

/// The scene's slip surface, if a body slides on a weak layer (BodyDesc::slidesOn; the scene
/// reader allows one surface, and one friction where several bodies give it).
void setSlipSurface(const SceneDesc& scene, World& world) {
    double friction = -1.0;
    for (const BodyDesc& body : scene.bodies) {
        if (body.slidesOn.empty()) continue;
        const auto weak = std::find_if(scene.bodies.begin(), scene.bodies.end(),
                                       [&](const BodyDesc& b) { return b.name == body.slidesOn; });
        world.slipMaterial = weak->materialIndex;
        friction = std::max(friction, body.slipFriction);
    }
    if (world.slipMaterial < 0) return;
    world.slipFriction =
        friction >= 0.0
            ? float(friction)
            : slipFrictionOfWeakLayer(world.materials[std::size_t(world.slipMaterial)].camClay.Md);
}

} // namespace

std::vector<double> estimateParticlesPerBody(const SceneDesc& sceneIn) {
    const SceneDesc scene = toLocalFrame(sceneIn);
    const int dim = scene.simulation.dimension;
    const double dx = scene.grid.dx;
    std::vector<Collider> colliders;
    for (const TerrainDesc& t : scene.terrains) colliders.push_back(Collider::fromDesc(t, dim));
    const std::vector<ThicknessField> fields = thicknessFields(scene);
    std::vector<SeedRegion> regions;
    std::vector<double> estimate;
    for (std::size_t bi = 0; bi < scene.bodies.size(); ++bi) {
        regions.push_back(regionOf(scene, bi, colliders, fields));
        const SeedRegion& region = regions.back();
        // Cell centres of a lattice coarse enough for kSamples points over the bounding box,
        // never finer than the grid: each inside one stands for (h/dx)^dim cells.
        constexpr double kSamples = 2e5;
        double cells = 1.0;
        for (int a = 0; a < dim; ++a)
            cells *= std::max(1.0, double(region.hi[a] - region.lo[a]) / dx);
        const double h = dx * std::max(1.0, std::pow(cells / kSamples, 1.0 / dim));
        std::array<long, 3> n{1, 1, 1};
        for (int a = 0; a < dim; ++a)
            n[a] = std::max(1L, long(std::ceil(double(region.hi[a] - region.lo[a]) / h)));
        std::size_t inside = 0;
        for (long i = 0; i < n[0]; ++i)
            for (long j = 0; j < n[1]; ++j)
                for (long k = 0; k < n[2]; ++k) {
                    const long idx[3] = {i, j, k};
                    Vec3f p = region.lo;
                    for (int a = 0; a < dim; ++a) p[a] += float((double(idx[a]) + 0.5) * h);
                    if (!region.inside(p)) continue;
                    bool taken = false;
                    for (std::size_t e = 0; e + 1 < regions.size() && !taken; ++e)
                        taken = regions[e].inside(p);
                    inside += !taken;
                }
        estimate.push_back(double(inside) * std::pow(h / dx, dim) * scene.grid.particlesPerCell);
    }
    return estimate;
}

std::unique_ptr<World> buildWorld(const SceneDesc& sceneIn, BuildStage stage,
                                  const BuildObserver& observer) {
    const SceneDesc scene = toLocalFrame(sceneIn); // a far-off DEM's snow next to 0
    auto world = std::make_unique<World>();
    World& w = *world;
    w.origin = scene.frameOrigin;
    w.dim = scene.simulation.dimension;
    w.dx = float(scene.grid.dx);
    w.transfer = scene.grid.transfer;
    w.flipBlend = float(scene.grid.flipBlend);
    w.flipRelaxationTime = float(scene.grid.flipRelaxationTime);
    w.xpicOrder = scene.grid.xpicOrder;
    w.cfl = float(scene.grid.cfl);
    w.maxDt = float(scene.grid.maxDt);
    w.gravity = toVec3f(scene.simulation.gravity);
    if (w.dim == 2) w.gravity[2] = 0.f;
    w.gravityRamp = float(scene.simulation.gravityRamp);
    w.sleep = scene.grid.sleep;
    w.sleepSpeed = float(scene.grid.sleepSpeed);
    w.sleepSteps = scene.grid.sleepSteps;
    w.domainMin = toVec3f(scene.simulation.domainMin);
    w.domainMax = toVec3f(scene.simulation.domainMax);
    for (const MaterialDesc& m : scene.materials)
        w.materials.push_back(Material::fromDesc(m, w.dim, scene.grid.dx));
    markSlabMaterials(scene, w.materials);
    for (const TerrainDesc& t : scene.terrains) w.colliders.push_back(Collider::fromDesc(t, w.dim));

    setSlipSurface(scene, w);

    w.particles.dim = w.dim;
    w.particles.dx = w.dx;
    if (stage == BuildStage::Bare) return world;
    if (observer.collidersBuilt) observer.collidersBuilt(w);
    const auto seeding = std::chrono::steady_clock::now();
    seedBodies(scene, w);
    if (observer.seeded)
        observer.seeded(
            w.particles.size(),
            std::chrono::duration<double>(std::chrono::steady_clock::now() - seeding).count());
    for (std::size_t i = 0; i < w.particles.size(); ++i) {
        const Material& m = w.materials[w.particles.material[i]];
        w.maxWaveSpeed = std::max(w.maxWaveSpeed, m.pWaveSpeed());
    }
    if (stage == BuildStage::Settled && scene.simulation.settle) {
        // Bodies seeded moving are not at rest: they wait outside while the rest settles.
        ParticleSet moving = w.particles.extractFlagged(kFlagOutsideSettling);
        w.particles.bucketByLeaf();
        const double cfl = settlingCfl(scene.simulation.settleCfl, scene.grid.cfl);
        SettleParams params{scene.simulation.settleMaxTime,
                            scene.simulation.settleTolerance,
                            cfl,
                            observer.interrupted,
                            observer.settling,
                            {}};
        for (const MaterialDesc& m : scene.materials) params.materialNames.push_back(m.name);
        w.settle = settleUnderGravity(w, params);
        w.particles.append(std::move(moving));
    }
    // An instant saw cuts the snowpack at rest (after settling): its cut's particles go now.
    w.particles.extractFlagged(kFlagInCut);
    for (PlasticState& s : w.particles.plastic) s.flags &= ~kFlagOutsideSettling;
    w.particles.bucketByLeaf();
    applyPlasticity(w, w.time); // the stress of the start state (and tau after bucketing)
    for (std::size_t i = 0; i < w.particles.size(); ++i)
        w.maxSpeed = std::max(w.maxSpeed, w.particles.v[i].norm());
    return world;
}

std::size_t removeOutflow(World& world) {
    ParticleSet& ps = world.particles;
    std::size_t outside = 0;
    for (std::size_t i = 0; i < ps.size(); ++i) {
        const Vec3f& x = ps.x[i];
        // A non-finite position is not outflow: the stability watch reports it.
        bool out = false;
        for (int a = 0; a < world.dim; ++a)
            out = out || x[a] < world.domainMin[a] || x[a] > world.domainMax[a];
        if (out) ps.plastic[i].flags |= kFlagOutside, ++outside;
    }
    if (outside == 0) return 0;
    const ParticleSet gone = ps.extractFlagged(kFlagOutside);
    for (float m : gone.mass) world.outflowMass += m;
    ps.bucketByLeaf();
    applyPlasticity(world, world.time); // bucketing leaves the stress undefined
    return outside;
}

} // namespace firn
