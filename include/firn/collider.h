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

class Collider {
public:
    /// Throws SceneError for shapes that cannot be built (an unreadable heightfield).
    static Collider fromDesc(const TerrainDesc& desc, int dim);

    /// Signed distance to the ground surface: > 0 above (outside), <= 0 inside.
    float signedDistance(const Vec3f& x) const;
    /// Outward unit normal of the nearest surface point.
    Vec3f normal(const Vec3f& x) const;
    /// Ground height under x (profile and plane; used to drape layers), m.
    float heightAt(float xCoord, float zCoord) const;

    /// Grid velocity after the boundary condition at a node inside the collider with outward
    /// normal n: separating motion is free; approaching motion loses its normal part and, for
    /// friction, the tangential part shrinks by mu |v_n| (Coulomb) or stops.
    Vec3f applyBoundary(const Vec3f& v, const Vec3f& n) const;

    Boundary boundary() const { return mBoundary; }
    /// True for ground that carries weight under `gravity`: profiles and heightfields, and
    /// planes that face against gravity by more than about 6 degrees (not walls or ceilings).
    bool carriesWeight(const Vec3f& gravity) const;
    /// The same collider with another boundary condition (the settling stage holds the ground
    /// sticky).
    Collider withBoundary(Boundary boundary) const {
        Collider c = *this;
        c.mBoundary = boundary;
        return c;
    }

private:
    TerrainShape mShape = TerrainShape::Plane;
    Boundary mBoundary = Boundary::Friction;
    float mFriction = 0.4f;
    int mDim = 3;
    Vec3f mPoint = Vec3f::Zero();
    Vec3f mNormal = Vec3f::UnitY();
    std::vector<std::array<float, 2>> mProfile;
    std::shared_ptr<const Heightfield> mHeightfield;

    // Nearest point on the profile polyline (x-y plane) and the sign of the side.
    void nearestOnProfile(float px, float py, float& cx, float& cy, float& sign) const;
};

} // namespace firn
