// The colliders' answers at the grid's nodes, kept from step to step.
#pragma once

#include <firn/collider.h>
#include <firn/grid.h>

#include <cstdint>
#include <memory>
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
    /// before and dropping those no step has used for a while. Serial; call after the grid's
    /// rebuild, before asking.
    void bind(const Grid& grid, std::size_t colliderCount);

    /// The outward normal of `collider` (index c) at node n of block b if the node lies within
    /// `reach` of it (Collider::clearOf, signedDistance <= reach), else nullptr. xn is the node's
    /// position. Only the thread that works on block b may ask about it.
    const Vec3f* contact(std::size_t b, int n, std::size_t c, const Collider& collider,
                         const Vec3f& xn, float reach);

    /// The slip surface's normal at node n of block b, `compute()` on the first ask.
    template <class Compute> const Vec3f& slipNormal(std::size_t b, int n, Compute&& compute) {
        Record& r = record(b, n, mColliderCount);
        if (r.state == kUnknown) r.normal = compute(), r.state = kInContact;
        return r.normal;
    }

    void clear();

    /// Leaves the store holds records for (at most about twice the bound grid's blocks).
    std::size_t storedLeaves() const;

private:
    enum : std::uint8_t { kUnknown = 0, kClear = 1, kInContact = 2 };
    struct Record {
        Vec3f normal = Vec3f::Zero();
        std::uint8_t state = kUnknown;
    };
    Record& record(std::size_t b, int n, std::size_t slot) {
        return mBlocks[b][std::size_t(n) * (mColliderCount + 1) + slot];
    }
    struct Leaves;
    std::unique_ptr<Leaves> mLeaves;
    std::vector<Record*> mBlocks; ///< per block of the bound grid: its leaf's records
    std::size_t mColliderCount = 0;
};

} // namespace firn
