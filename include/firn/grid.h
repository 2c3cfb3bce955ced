// The sparse background grid: OpenVDB trees whose leaves are the particle leaves dilated by the
// quadratic stencil. Only leaves that particles can reach exist; empty space costs nothing.
// Node i sits at world position i * dx; a leaf holds nodes origin + [0,8)^3 at VDB offsets
// (x&7)<<6 | (y&7)<<3 | (z&7). In 2D only the z = 0 slice of each leaf is used.
#pragma once

#include <firn/particles.h>

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

namespace firn {

constexpr int kLeafNodes = kLeafDim * kLeafDim * kLeafDim;

/// World position of node (i, j, k) of the leaf with key `key` (2D: k = 0, z = 0), m.
inline Vec3f nodePosition(const LeafKey& key, int i, int j, int k, float dx, int dim) {
    return Vec3f(float(key[0] * kLeafDim + i) * dx, float(key[1] * kLeafDim + j) * dx,
                 dim == 3 ? float(key[2] * kLeafDim + k) * dx : 0.f);
}

/// Neighbour table entry: index per offset o in {0,1}^d (bit 0 x, bit 1 y, bit 2 z), or -1.
using NeighbourIndices = std::array<std::int32_t, 8>;

class Grid {
public:
    Grid();
    ~Grid();
    Grid(const Grid&) = delete;
    Grid& operator=(const Grid&) = delete;

    /// Rebuilds the active topology from the particle leaves: grid leaf k + o for every particle
    /// leaf k and o in {0,1}^d (a particle in leaf k reaches nodes 8k .. 8k + 9). Leaves that
    /// stay are reused. With `auxChannels` > 0 every leaf also gets that many aux floats per node.
    void rebuild(const ParticleSet& particles, int auxChannels);

    std::size_t blockCount() const;
    const LeafKey& blockKey(std::size_t b) const;
    /// Names the blocks' keys: it changes whenever they change, and no two topologies of any
    /// grid in the process share one (a store keyed by blocks, NodeContacts, can skip a bind).
    std::uint64_t topologyId() const;
    // Inline: the transfers, the grid update and the sticky walls ask per node.
    float* mass(std::size_t b) { return mMassData[b]; } ///< kLeafNodes floats (VDB leaf buffer)
    float* velocity(std::size_t b) { return mVelocityData[b]; } ///< 3 * kLeafNodes floats
    float* aux(std::size_t b) { return mAux + b * mAuxStride; } ///< auxChannels * kLeafNodes
    const float* mass(std::size_t b) const { return mMassData[b]; }
    const float* velocity(std::size_t b) const { return mVelocityData[b]; }
    const float* aux(std::size_t b) const { return mAux + b * mAuxStride; }
    int auxChannels() const;

    /// The block of leaf key `key`, or -1 where the grid has none.
    std::int32_t blockOf(const LeafKey& key) const;

    /// For particle leaf l: the grid block of key leaves[l] + o.
    const std::vector<NeighbourIndices>& blocksOfParticleLeaf() const;
    /// For grid block b: the particle leaf of key blockKey(b) - o, or -1.
    const std::vector<NeighbourIndices>& particleLeavesOfBlock() const;

    /// Nodes with mass > 0 (computed by the caller's last P2G; counted on demand).
    std::size_t activeNodeCount(int dim) const;

private:
    struct Impl;
    std::vector<float*> mMassData, mVelocityData; ///< each block's leaf buffer (Impl's trees)
    float* mAux = nullptr;
    std::size_t mAuxStride = 0;
    std::unique_ptr<Impl> mImpl;
};

} // namespace firn
