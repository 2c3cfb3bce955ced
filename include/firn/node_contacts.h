// The colliders' answers at the grid's nodes, kept from step to step.
#pragma once

#include <firn/collider.h>
#include <firn/grid.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

namespace firn {

/// Whether a grid node lies within reach of each collider, the collider's outward normal there,
/// and the slip surface's normal, kept per VDB leaf across steps. A node's answers depend on its
/// position alone, and the grid's leaves persist while the snow moves on, so each is computed
/// once, the first time a step asks, instead of at every step: the heightfield's lookups were
/// about 12 % of a hazard run (bench/README.md, the helix). Results are bitwise those of asking
/// the colliders. The colliders' geometry must stay as it was at the first ask (settling's
/// held-at-rest copies keep it); clear() otherwise.
class NodeContacts {
public:
    NodeContacts();
    ~NodeContacts();
    NodeContacts(NodeContacts&&) noexcept;
    NodeContacts& operator=(NodeContacts&&) noexcept;

    /// Binds each block of `grid` to its leaf's record, creating records for leaves not seen
    /// before and dropping those no step has used for a while. `slipSurface`: whether slipNormal
    /// will be asked; `wallSides`: whether wallSide will be. Serial; call after the grid's
    /// rebuild, before asking.
    void bind(const Grid& grid, std::size_t colliderCount, bool slipSurface,
              bool wallSides = false);

    /// The outward normal of `collider` (index c) at node n of block b if the node lies within
    /// `reach` of it (Collider::clearOf, signedDistance <= reach), else none. xn is the node's
    /// position. Only the thread that works on block b may ask about it.
    std::optional<Vec3f> contact(std::size_t b, int n, std::size_t c, const Collider& collider,
                                 const Vec3f& xn, float reach);

    /// The slip surface's normal at node n of block b, `compute()` on the first ask.
    template <class Compute> Vec3f slipNormal(std::size_t b, int n, Compute&& compute) {
        std::uint16_t& state = this->state(b, n, mSlipSlot);
        if (state == kUnknown) state = keep(b, compute());
        return normalOf(b, state);
    }

    /// Where a node lies against a collider taken as a sticky wall (firn/sticky_walls.h).
    struct WallSide {
        enum Kind : std::uint8_t { kOutside, kOnSurface, kInside };
        Kind kind = kOutside;
        Vec3f mirror = Vec3f::Zero(); ///< kInside: the node's image across the surface
    };

    /// Node n of block b (position xn) against `collider` (index c): outside it beyond
    /// `tolerance`, on its surface (signed distance phi within `tolerance` either side), or
    /// inside, with the mirror point xn - 2 phi normal(xn). Bitwise what the collider gives.
    /// Needs bind(..., wallSides = true); only the thread that works on block b may ask.
    WallSide wallSide(std::size_t b, int n, std::size_t c, const Collider& collider,
                      const Vec3f& xn, float tolerance);

    void clear();

    /// Leaves the store holds records for (at most about twice the bound grid's blocks).
    std::size_t storedLeaves() const;

    /// Bytes the store's records take (their vectors' capacities).
    std::size_t storedBytes() const;

private:
    /// A node's answer per slot: per collider, then per collider as a sticky wall (when asked
    /// for), then the slip surface. Unknown, clear (a wall: outside), on a wall's surface, or in
    /// contact with its normal (a wall: the mirror point) at normals[state - kInContact] of the
    /// leaf. The vectors are kept only for the nodes in contact, a thin shell of a leaf next to
    /// the ground: 2 bytes a node and slot instead of a 16-byte record (path3d: 26 MB of records
    /// at 70 000 particles). A leaf holds at most 512 x slots vectors, so 16 bits suffice for up
    /// to 127 slots (63 colliders with walls; bind throws beyond).
    enum : std::uint16_t { kUnknown = 0, kClear = 1, kOnSurface = 2, kInContact = 3 };
    struct Leaf;
    std::uint16_t& state(std::size_t b, int n, std::size_t slot);
    std::uint16_t keep(std::size_t b, const Vec3f& normal);
    const Vec3f& normalOf(std::size_t b, std::uint16_t state) const;
    struct Leaves;
    std::unique_ptr<Leaves> mLeaves;
    std::vector<Leaf*> mBlocks; ///< per block of the bound grid: its leaf's records
    std::size_t mColliderCount = 0;
    std::size_t mSlots = 0;    ///< colliders, walls and the slip surface's normal when asked for
    std::size_t mWallSlot = 0; ///< the first wall's slot
    std::size_t mSlipSlot = 0;
};

} // namespace firn
