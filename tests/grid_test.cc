// The sparse grid's topology follows the particle leaves: its blocks, the neighbour tables that
// P2G and G2P walk, and the id that lets per-block stores skip a rebinding.
#include "test_util.h"

#include <firn/grid.h>
#include <firn/solver.h>

#include <catch2/catch.hpp>

#include <algorithm>
#include <set>

using namespace firn;

namespace {

/// Each table entry against a search of the other side's keys (-1 where there is none), and
/// the blocks are exactly the particle leaves shifted by {0,1}^d, sorted.
void checkTopology(const Grid& grid, const ParticleSet& ps) {
    const int offsets = 1 << ps.dim;
    std::set<LeafKey> expected;
    for (const LeafKey& k : ps.leaves)
        for (int o = 0; o < offsets; ++o)
            expected.insert({k[0] + (o & 1), k[1] + ((o >> 1) & 1), k[2] + ((o >> 2) & 1)});
    REQUIRE(grid.blockCount() == expected.size());
    std::size_t b = 0;
    for (const LeafKey& k : expected) REQUIRE(grid.blockKey(b++) == k);
    const auto indexIn = [](const std::vector<LeafKey>& keys, const LeafKey& k) {
        const auto it = std::find(keys.begin(), keys.end(), k);
        return it == keys.end() ? -1 : std::int32_t(it - keys.begin());
    };
    std::vector<LeafKey> blocks;
    for (std::size_t i = 0; i < grid.blockCount(); ++i) blocks.push_back(grid.blockKey(i));
    for (std::size_t l = 0; l < ps.leafCount(); ++l)
        for (int o = 0; o < 8; ++o) {
            const LeafKey& k = ps.leaves[l];
            const LeafKey up = {k[0] + (o & 1), k[1] + ((o >> 1) & 1), k[2] + ((o >> 2) & 1)};
            REQUIRE(grid.blocksOfParticleLeaf()[l][o] == (o < offsets ? indexIn(blocks, up) : -1));
        }
    for (std::size_t i = 0; i < blocks.size(); ++i)
        for (int o = 0; o < 8; ++o) {
            const LeafKey& k = blocks[i];
            const LeafKey down = {k[0] - (o & 1), k[1] - ((o >> 1) & 1), k[2] - ((o >> 2) & 1)};
            REQUIRE(grid.particleLeavesOfBlock()[i][o] ==
                    (o < offsets ? indexIn(ps.leaves, down) : -1));
        }
}

} // namespace

TEST_CASE("The grid's blocks and neighbour tables follow the particle leaves, and its topology id "
          "changes with them",
          "[grid]") {
    for (int dim = 2; dim <= 3; ++dim) {
        const std::string box = dim == 3 ? "min = [-0.9, -0.2, -0.6]\nmax = [0.6, 0.5, 0.7]\n"
                                         : "min = [-0.9, -0.2]\nmax = [0.6, 0.5]\n";
        auto world = buildWorld(
            test::sceneFromText("[simulation]\nname = \"t\"\ndimension = " + std::to_string(dim) +
                                "\nend_time = 1.0\n[grid]\ndx = 0.05\n[[material]]\nname = \"e\"\n"
                                "model = \"elastic\"\ndensity = 100.0\n[[body]]\nmaterial = \"e\"\n"
                                "shape = \"box\"\n" +
                                box));
        ParticleSet& ps = world->particles;
        Grid& grid = world->grid;
        grid.rebuild(ps, 0);
        REQUIRE(ps.leafCount() > 4); // the box spans several leaves along each axis
        checkTopology(grid, ps);
        const std::uint64_t first = grid.topologyId();
        grid.rebuild(ps, 3); // the same leaves: the same blocks, whatever the aux channels
        REQUIRE(grid.topologyId() == first);
        // Move the particles a third of a leaf at a time: some steps change the leaves.
        int changed = 0;
        for (int step = 0; step < 6; ++step) {
            const std::uint64_t before = grid.topologyId();
            for (Vec3f& x : ps.x) x += Vec3f(0.13f, -0.05f, dim == 3 ? 0.07f : 0.f);
            ps.bucketByLeaf();
            grid.rebuild(ps, 0);
            checkTopology(grid, ps);
            changed += grid.topologyId() != before;
        }
        REQUIRE(changed > 0);
        // Another grid built from the same leaves has its own id (stores are bound to one grid).
        Grid other;
        other.rebuild(ps, 0);
        REQUIRE(other.topologyId() != grid.topologyId());
    }
}
