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
    /// will be asked. Serial; call after the grid's rebuild, before asking. A grid whose blocks
    /// are those of the last bind (the same Grid::topologyId) keeps its binding: most steps.
    void bind(const Grid& grid, std::size_t colliderCount, bool slipSurface);

    /// The outward normal of `collider` (index c) at node n of block b if the node lies within
    /// `reach` of it (Collider::clearOf, signedDistance <= reach), else none. xn is the node's
    /// position. Only the thread that works on block b may ask about it. Inline for the known
    /// answers (the grid update asks every node with mass, every step).
    std::optional<Vec3f> contact(std::size_t b, int n, std::size_t c, const Collider& collider,
                                 const Vec3f& xn, float reach) {
        const std::uint16_t s = mStates[b][std::size_t(n) * mSlots + c];
        if (s == kClear) return std::nullopt;
        if (s == kUnknown) return firstContact(b, n, c, collider, xn, reach);
        return (*mNormals[b])[s - kInContact];
    }

    /// The slip surface's normal at node n of block b, `compute()` on the first ask.
    template <class Compute> Vec3f slipNormal(std::size_t b, int n, Compute&& compute) {
        std::uint16_t& state = this->state(b, n, mSlipSlot);
        if (state == kUnknown) state = keep(b, compute());
        return normalOf(b, state);
    }

    /// A node that the sticky walls (firn/sticky_walls.h) hold at rest, on a wall's surface, or
    /// mirror, inside a wall, with its image across the surface.
    struct WallNode {
        Vec3f mirror = Vec3f::Zero(); ///< a ghost's mirror point
        std::uint16_t node = 0;       ///< index in the leaf
        bool ghost = false;
    };

    /// The nodes of block b that `classify(n, node)` puts on or inside a wall (it fills `node`
    /// and returns true), in node order. The store asks about every node of the leaf (2D: the
    /// 64 of its plane) the first time a step asks for the leaf, and keeps the list: a step
    /// then visits the few nodes next to a wall instead of asking each node with mass (the
    /// sticky walls were 9 % of `slope2d`). Only the thread that works on block b may ask.
    template <class Classify>
    const std::vector<WallNode>& wallNodes(std::size_t b, int dim, Classify&& classify) {
        if (const std::vector<WallNode>* known = knownWalls(b)) return *known;
        std::vector<WallNode> found;
        for (int n = 0; n < kLeafNodes; n += dim == 3 ? 1 : kLeafDim) {
            WallNode node;
            if (!classify(n, node)) continue;
            node.node = std::uint16_t(n);
            found.push_back(node);
        }
        return keepWalls(b, std::move(found));
    }

    void clear();

    /// Leaves the store holds records for (at most about twice the bound grid's blocks).
    std::size_t storedLeaves() const;

    /// Bytes the store's records take (their vectors' capacities).
    std::size_t storedBytes() const;

private:
    /// A node's answer per slot: per collider, then the slip surface. Unknown, clear, or in
    /// contact with its normal at normals[state - kInContact] of the leaf. The vectors are kept
    /// only for the nodes in contact, a thin shell of a leaf next to the ground: 2 bytes a node
    /// and slot instead of a 16-byte record (path3d: 26 MB of records at 70 000 particles). A
    /// leaf holds at most 512 x slots vectors, so 16 bits suffice for up to 127 slots (bind
    /// throws beyond).
    enum : std::uint16_t { kUnknown = 0, kClear = 1, kInContact = 2 };
    struct Leaf;
    std::uint16_t& state(std::size_t b, int n, std::size_t slot);
    std::uint16_t keep(std::size_t b, const Vec3f& normal);
    const Vec3f& normalOf(std::size_t b, std::uint16_t state) const;
    std::optional<Vec3f> firstContact(std::size_t b, int n, std::size_t c, const Collider& collider,
                                      const Vec3f& xn, float reach);
    const std::vector<WallNode>* knownWalls(std::size_t b) const;
    const std::vector<WallNode>& keepWalls(std::size_t b, std::vector<WallNode>&& walls);
    struct Leaves;
    std::unique_ptr<Leaves> mLeaves;
    std::vector<Leaf*> mBlocks;                ///< per block of the bound grid: its leaf's records
    std::vector<std::uint16_t*> mStates;       ///< per block: its leaf's states (never resized)
    std::vector<std::vector<Vec3f>*> mNormals; ///< per block: its leaf's normals
    std::uint64_t mBoundTopology = 0;          ///< Grid::topologyId of the bound grid (0: none)
    std::size_t mColliderCount = 0;
    std::size_t mSlots = 0; ///< colliders and the slip surface's normal when asked for
    std::size_t mSlipSlot = 0;
};

} // namespace firn
