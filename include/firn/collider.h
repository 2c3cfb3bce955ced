// Terrain colliders as signed distance functions, with Coulomb friction, slip or sticky
// boundary conditions applied to grid node velocities (Stomakhin et al. 2013, sec. 8).
#pragma once

#include <firn/dem.h>
#include <firn/material.h>
#include <firn/scene.h>

#include <array>
#include <memory>
#include <vector>

namespace firn {

/// A node on a collider surface is in contact. Node positions i * dx are rounded in float, so a
/// node exactly on a plane can land one ulp outside; this tolerance (of dx) keeps it in contact.
constexpr float kContactTolerance = 1e-4f;

/// The part of a bed law that acts on the particles of the flow over the bed, spread over the
/// column's depth (applyBasalDrag, firn/solver.h); the law's Coulomb part mu sigma_b acts at the
/// grid's contact nodes (Collider::applyBoundary). A pure function of the flow's state.
struct BasalDrag {
    Boundary law = Boundary::Friction; ///< Voellmy or SamosAT; the others have no drag
    float xi = 0.f;                    ///< Voellmy's turbulent friction, m/s^2
    float mu = 0.f;                    ///< samosAT's Coulomb coefficient
    float tau0 = 0.f;                  ///< samosAT's minimum shear stress, Pa
    float rs0 = 0.222f, kappa = 0.43f, roughness = 0.05f, b = 4.13f; ///< samosAT (R in m)

    bool active() const { return law == Boundary::Voellmy || law == Boundary::SamosAT; }
    /// The factor the tangential velocity (speed u, m/s) of a particle is multiplied by over dt,
    /// in a column of snow of thickness h (normal to the bed, m) and density rho (kg/m^3) under
    /// gravity g (m/s^2) whose component normal to the bed is gNormal. Each term decelerates the
    /// column by its basal shear stress over rho h:
    /// - Voellmy: rho g u^2 / xi, implicit: u' = u / (1 + g u dt / (xi h)) (RAMMS);
    /// - samosAT (Sampl and Zwinger 2004; AvaFrame com1DFA's default): tau = tau0 +
    ///   mu (1 + Rs0 / (Rs0 + Rs)) sigma_b + rho u^2 / (ln(h / R) / kappa + B)^2 with
    ///   sigma_b = rho gNormal h and Rs = rho u^2 / sigma_b; ln(h / R) no less than 0 (AvaFrame).
    ///   The turbulent term is implicit as Voellmy's, then the terms beyond mu sigma_b (tau0, and
    ///   mu Rs0 / (Rs0 + Rs) sigma_b: twice the friction at rest, mu at speed) take at most the
    ///   speed that is left: they stop a particle, never reverse it.
    float speedScale(float u, float h, float rho, float g, float gNormal, float dt) const;
    /// The velocity v after dt over a bed of outward normal n under `gravity`: its tangential
    /// part scaled by speedScale. Out of line on purpose: inlined into the parallel loop of
    /// applyBasalDrag, the compiler made two versions of this arithmetic that contract it into
    /// FMAs differently, and the one a particle ran depended on where TBB split the range, so
    /// results differed by an ulp from run to run (path3d, 2 threads, 2026-12-07).
    Vec3f applied(const Vec3f& v, const Vec3f& n, float h, float rho, const Vec3f& gravity,
                  float dt) const;
};

class Collider {
public:
    /// Throws SceneError for shapes that cannot be built (an unreadable heightfield). A
    /// heightfield is read (readDem, firn/gis.h) and moved by the desc's fileOrigin.
    static Collider fromDesc(const TerrainDesc& desc, int dim);

    /// Signed distance to the ground surface: > 0 above (outside), <= 0 inside.
    float signedDistance(const Vec3f& x) const;
    /// True only where signedDistance(x) > reach, found cheaply: a profile bounds its distance
    /// by the height above its ground over x instead of searching its segments (other shapes
    /// answer false). False tells nothing (ask signedDistance). The grid's nodes far above a
    /// profile skip the search.
    bool clearOf(const Vec3f& x, float reach) const;
    /// Outward unit normal of the nearest surface point.
    Vec3f normal(const Vec3f& x) const;
    /// The ground's slope (dh/dx, dh/dz) where a heightfield was looked up, for normal(x, slope).
    struct Slope {
        float dhdx = 0.f, dhdz = 0.f;
    };
    /// signedDistance(x), keeping in `slope` what normal(x, slope) needs: a heightfield looks its
    /// cell up once for both (the basal drag asks both of most particles, every step).
    float signedDistance(const Vec3f& x, Slope& slope) const;
    /// normal(x), bitwise, from the slope that signedDistance(x, slope) kept.
    Vec3f normal(const Vec3f& x, const Slope& slope) const;
    /// Ground height under x (profile and plane; used to drape layers), m.
    float heightAt(float xCoord, float zCoord) const;
    /// True where this collider has ground of its own under (x, z): a heightfield within its
    /// grid's extent (beyond it the edge heights continue), every other shape everywhere.
    bool covers(double xCoord, double zCoord) const;

    /// Grid velocity after the boundary condition at a node inside the collider with outward
    /// normal n: separating motion is free; approaching motion loses its normal part and, for
    /// friction, voellmy and samosat, the tangential part shrinks by mu |v_n| (Coulomb) or
    /// stops. The rest of voellmy and samosat acts on particles (BasalDrag).
    Vec3f applyBoundary(const Vec3f& v, const Vec3f& n) const;

    Boundary boundary() const { return mBoundary; }
    /// What the bed law does to the flow's particles (inactive but for voellmy and samosat).
    const BasalDrag& basalDrag() const { return mDrag; }
    /// The DEM of a heightfield collider (in the simulation's frame), else null.
    const Heightfield* heightfield() const { return mHeightfield.get(); }
    /// True for ground that carries weight under `gravity`: profiles and heightfields, and
    /// planes that face against gravity by more than about 6 degrees (not walls or ceilings).
    bool carriesWeight(const Vec3f& gravity) const;
    /// The same collider holding every node in contact at rest, as friction does where the
    /// contact sticks: the settling stage's ground, so that the settled state is in equilibrium
    /// under the run's own contact. A sticky collider stays as it is.
    Collider heldAtRest() const {
        Collider c = *this;
        if (mBoundary != Boundary::Sticky) c.mBoundary = Boundary::Sticky, c.mHeldAtRest = true;
        c.mDrag.law = Boundary::Sticky; // held: no basal drag either
        return c;
    }
    /// True for a sticky collider whose inside nodes mirror the outside (firn/sticky_walls.h);
    /// false for one held at rest.
    bool mirrorsInside() const { return mBoundary == Boundary::Sticky && !mHeldAtRest; }

private:
    TerrainShape mShape = TerrainShape::Plane;
    Boundary mBoundary = Boundary::Friction;
    bool mHeldAtRest = false; ///< sticky by zeroed nodes (heldAtRest)
    float mFriction = 0.4f;
    BasalDrag mDrag;
    int mDim = 3;
    Vec3f mPoint = Vec3f::Zero();
    Vec3f mNormal = Vec3f::UnitY();
    std::vector<std::array<float, 2>> mProfile;
    float mProfileSecant = 1.f; ///< sqrt(1 + slope^2) of the profile's steepest segment
    std::shared_ptr<const Heightfield> mHeightfield;

    // Nearest point on the profile polyline (x-y plane) and the sign of the side.
    void nearestOnProfile(float px, float py, float& cx, float& cy, float& sign) const;
    // Index of the profile segment over x (its first and last extend past the ends).
    std::size_t profileSegmentAt(float xCoord) const;
};

} // namespace firn
