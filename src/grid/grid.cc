#include <firn/grid.h>

#include <openvdb/openvdb.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <atomic>

namespace firn {

namespace {
// Trees with 8^3-child internal nodes (leaf 8^3, internal nodes 64^3 and 512^3 voxels) instead of
// OpenVDB's default 5-4-3: a default top node holds 32^3 child slots (~0.25 MB for float, 0.5 MB
// for vec3f), and a body that straddles the origin touches eight of them per tree, ~35 bytes per
// particle at 200 000 particles for slots that stay empty. The leaves are the standard ones.
using MassTree = openvdb::tree::Tree4<float, 3, 3, 3>::Type;
using VelocityTree = openvdb::tree::Tree4<openvdb::Vec3f, 3, 3, 3>::Type;
using MassLeaf = MassTree::LeafNodeType;
using VelocityLeaf = VelocityTree::LeafNodeType;

openvdb::Coord leafOrigin(const LeafKey& k) {
    return openvdb::Coord(k[0] * kLeafDim, k[1] * kLeafDim, k[2] * kLeafDim);
}

int offsetCount(int dim) {
    return 1 << dim;
}

LeafKey shifted(const LeafKey& k, int o, int sign) {
    return {k[0] + sign * (o & 1), k[1] + sign * ((o >> 1) & 1), k[2] + sign * ((o >> 2) & 1)};
}

std::int32_t findKey(const std::vector<LeafKey>& keys, const LeafKey& k) {
    auto it = std::lower_bound(keys.begin(), keys.end(), k);
    return (it != keys.end() && *it == k) ? static_cast<std::int32_t>(it - keys.begin()) : -1;
}

std::uint64_t nextTopologyId() {
    static std::atomic<std::uint64_t> last{0};
    return ++last;
}
} // namespace

struct Grid::Impl {
    std::vector<float*>& massData;     ///< Grid's, the leaves' buffers by block
    std::vector<float*>& velocityData; ///< (kept there so that the accessors inline)
    explicit Impl(Grid& grid)
        : massData(grid.mMassData)
        , velocityData(grid.mVelocityData) {}
    MassTree massTree{0.f};
    VelocityTree velocityTree{openvdb::Vec3f(0.f)};
    std::vector<LeafKey> keys;
    std::uint64_t topologyId = nextTopologyId();
    std::vector<MassLeaf*> massLeaves;
    std::vector<VelocityLeaf*> velocityLeaves;
    std::vector<float> aux;
    int auxChannels = 0;
    std::vector<NeighbourIndices> blocksOfParticleLeaf;
    std::vector<NeighbourIndices> particleLeavesOfBlock;
    std::vector<LeafKey> particleLeaves; ///< what the topology was built from (a function of
    int particleDim = 0;                 ///< the particle leaves and the dimension alone)

    // Runs when a particle changes leaf, which on a flowing avalanche is most steps: the key
    // searches and the two trees' rebuilds are parallel (each result is independent of the
    // thread count: the sort orders distinct keys, the searches write their own entries).
    void buildTopology(const ParticleSet& particles) {
        particleLeaves = particles.leaves;
        particleDim = particles.dim;
        const int no = offsetCount(particles.dim);
        std::vector<LeafKey> newKeys;
        newKeys.reserve(particles.leafCount() * no);
        for (const LeafKey& k : particles.leaves)
            for (int o = 0; o < no; ++o) newKeys.push_back(shifted(k, o, +1));
        tbb::parallel_sort(newKeys.begin(), newKeys.end());
        newKeys.erase(std::unique(newKeys.begin(), newKeys.end()), newKeys.end());
        if (newKeys != keys) {
            tbb::parallel_invoke([&] { retopologise(massTree, massLeaves, newKeys); },
                                 [&] { retopologise(velocityTree, velocityLeaves, newKeys); });
            keys.swap(newKeys);
            // A leaf keeps its buffer while it lives (P2G writes through these pointers).
            massData.resize(keys.size());
            velocityData.resize(keys.size());
            for (std::size_t b = 0; b < keys.size(); ++b) {
                massData[b] = massLeaves[b]->buffer().data();
                velocityData[b] = reinterpret_cast<float*>(velocityLeaves[b]->buffer().data());
            }
            topologyId = nextTopologyId();
        }
        const auto neighbours = [no](const std::vector<LeafKey>& from, int sign,
                                     const std::vector<LeafKey>& in,
                                     std::vector<NeighbourIndices>& out) {
            out.resize(from.size());
            tbb::parallel_for(tbb::blocked_range<std::size_t>(0, from.size(), 256),
                              [&](const auto& r) {
                                  for (std::size_t l = r.begin(); l != r.end(); ++l) {
                                      out[l].fill(-1);
                                      for (int o = 0; o < no; ++o)
                                          out[l][o] = findKey(in, shifted(from[l], o, sign));
                                  }
                              });
        };
        neighbours(particles.leaves, +1, keys, blocksOfParticleLeaf);
        neighbours(keys, -1, particles.leaves, particleLeavesOfBlock);
    }

    // Keeps the leaves that stay (their buffers are rewritten by every P2G), frees the rest
    // and allocates the new ones: no per-step reallocation of a steady topology.
    template <typename TreeT>
    static void retopologise(TreeT& tree, std::vector<typename TreeT::LeafNodeType*>& leaves,
                             const std::vector<LeafKey>& newKeys) {
        using LeafT = typename TreeT::LeafNodeType;
        leaves.resize(newKeys.size());
        for (std::size_t b = 0; b < newKeys.size(); ++b) {
            const openvdb::Coord origin = leafOrigin(newKeys[b]);
            LeafT* leaf = tree.template stealNode<LeafT>(origin, tree.background(), false);
            leaves[b] = leaf ? leaf : new LeafT(origin, tree.background(), true);
        }
        tree.clear();
        for (LeafT* leaf : leaves) tree.addLeaf(leaf);
    }
};

Grid::Grid()
    : mImpl(new Impl(*this)) {}
Grid::~Grid() = default;

void Grid::rebuild(const ParticleSet& particles, int auxChannels) {
    Impl& g = *mImpl;
    // Most steps no particle changes leaf (ParticleSet::bucketByLeaf): the topology stands.
    if (particles.leaves != g.particleLeaves || particles.dim != g.particleDim || g.keys.empty())
        g.buildTopology(particles);
    g.auxChannels = auxChannels;
    g.aux.resize(std::size_t(auxChannels) * kLeafNodes * g.keys.size());
    mAux = g.aux.data();
    mAuxStride = std::size_t(auxChannels) * kLeafNodes;
}

std::size_t Grid::blockCount() const {
    return mImpl->keys.size();
}
const LeafKey& Grid::blockKey(std::size_t b) const {
    return mImpl->keys[b];
}
std::uint64_t Grid::topologyId() const {
    return mImpl->topologyId;
}
int Grid::auxChannels() const {
    return mImpl->auxChannels;
}

std::int32_t Grid::blockOf(const LeafKey& key) const {
    return findKey(mImpl->keys, key);
}

const std::vector<NeighbourIndices>& Grid::blocksOfParticleLeaf() const {
    return mImpl->blocksOfParticleLeaf;
}
const std::vector<NeighbourIndices>& Grid::particleLeavesOfBlock() const {
    return mImpl->particleLeavesOfBlock;
}

std::size_t Grid::activeNodeCount(int dim) const {
    std::size_t n = 0;
    const int nz = dim == 3 ? kLeafDim : 1;
    for (std::size_t b = 0; b < blockCount(); ++b) {
        const float* m = mass(b);
        for (int i = 0; i < kLeafDim; ++i)
            for (int j = 0; j < kLeafDim; ++j)
                for (int k = 0; k < nz; ++k) n += m[(i << 6) | (j << 3) | k] > 0.f;
    }
    return n;
}

} // namespace firn
