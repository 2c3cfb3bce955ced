// The per-leaf store of the colliders' answers at grid nodes gives what the colliders give.
#include "test_util.h"

#include <firn/node_contacts.h>
#include <firn/solver.h>

#include <catch2/catch.hpp>

using namespace firn;

namespace {

/// A block of elastic snow on a tilted plane (3D) or a bent profile (2D), and a second plane.
std::unique_ptr<World> blockOnTerrain(int dim) {
    const std::string terrain =
        dim == 3 ? "[[terrain]]\nshape = \"plane\"\npoint = [0.0, 0.0, 0.0]\n"
                   "normal = [-0.3, 1.0, 0.2]\nboundary = \"slip\"\n"
                 : "[[terrain]]\nshape = \"profile\"\n"
                   "points = [[-5.0, 1.5], [0.0, 0.0], [0.7, -0.1], [5.0, -0.3]]\n"
                   "boundary = \"slip\"\n";
    const std::string wall = dim == 3 ? "[[terrain]]\nshape = \"plane\"\npoint = [-0.5, 0.0, 0.0]\n"
                                        "normal = [1.0, 0.0, 0.0]\nboundary = \"slip\"\n"
                                      : "[[terrain]]\nshape = \"plane\"\npoint = [-0.5, 0.0]\n"
                                        "normal = [1.0, 0.0]\nboundary = \"slip\"\n";
    const std::string box = dim == 3 ? "min = [-0.4, -0.2, -0.3]\nmax = [0.6, 0.5, 0.4]\n"
                                     : "min = [-0.4, -0.2]\nmax = [0.6, 0.5]\n";
    const std::string text =
        "[simulation]\nname = \"t\"\ndimension = " + std::to_string(dim) +
        "\nend_time = 1.0\n[grid]\ndx = 0.05\n[[material]]\nname = \"e\"\nmodel = \"elastic\"\n"
        "density = 100.0\n[[body]]\nmaterial = \"e\"\nshape = \"box\"\n" +
        box + terrain + wall;
    return buildWorld(test::sceneFromText(text));
}

/// Every node of every block: the store's answer is bitwise the collider's. Returns the
/// nodes in contact (so that the test knows it asked about some).
int compareAll(World& world, NodeContacts& contacts, float reach) {
    int inContact = 0;
    for (std::size_t b = 0; b < world.grid.blockCount(); ++b)
        for (int n = 0; n < kLeafNodes; ++n) {
            if (world.dim == 2 && (n & 7)) continue;
            const Vec3f xn = nodePosition(world.grid.blockKey(b), n >> 6, (n >> 3) & 7, n & 7,
                                          world.dx, world.dim);
            for (std::size_t c = 0; c < world.colliders.size(); ++c) {
                const Collider& collider = world.colliders[c];
                const bool within =
                    !collider.clearOf(xn, reach) && collider.signedDistance(xn) <= reach;
                const auto normal = contacts.contact(b, n, c, collider, xn, reach);
                REQUIRE(normal.has_value() == within);
                if (!within) continue;
                ++inContact;
                REQUIRE(*normal == collider.normal(xn));
                REQUIRE(*contacts.contact(b, n, c, collider, xn, reach) == *normal); // kept
            }
        }
    return inContact;
}

} // namespace

TEST_CASE("Node contacts kept per leaf answer as the colliders do, as the grid moves",
          "[collider]") {
    for (int dim = 2; dim <= 3; ++dim) {
        auto world = blockOnTerrain(dim);
        ParticleSet& ps = world->particles;
        const float reach = world->dx; // a cell: more nodes in contact than the solver asks
        NodeContacts contacts;
        world->grid.rebuild(ps, 0);
        contacts.bind(world->grid, world->colliders.size(), false);
        const int inContact = compareAll(*world, contacts, reach);
        REQUIRE(inContact > 0);
        // Normals are kept for the nodes in contact only: 2 bytes a node and collider, 12 a
        // normal (twice that for a vector's growth), where a record per node took 16.
        const std::size_t slots = world->colliders.size();
        INFO("stored " << contacts.storedBytes() << " bytes, " << inContact << " in contact");
        REQUIRE(contacts.storedBytes() <=
                world->grid.blockCount() * kLeafNodes * slots * 2 + 24 * std::size_t(inContact));
        // The slip surface's normal: computed on the first ask, then kept.
        contacts.bind(world->grid, world->colliders.size(), true);
        int computed = 0;
        for (int pass = 0; pass < 2; ++pass)
            for (int n = 0; n < kLeafNodes; n += 7) {
                const Vec3f normal = contacts.slipNormal(0, n, [&] {
                    ++computed;
                    return Vec3f(0.f, 1.f, float(n));
                });
                REQUIRE(normal == Vec3f(0.f, 1.f, float(n)));
            }
        REQUIRE(computed == (kLeafNodes + 6) / 7);
        REQUIRE(compareAll(*world, contacts, reach) == inContact);
        // Move the snow a leaf and a half down-slope, step by step: leaves come and go, blocks
        // are renumbered, and the leaves that stay answer from the store. Then far away (the
        // store drops the leaves left behind) and back.
        const Vec3f shift(0.6f * world->dx, -0.2f * world->dx, dim == 3 ? 0.3f * world->dx : 0.f);
        for (int step = 0; step < 20; ++step) {
            for (Vec3f& x : ps.x) x += shift;
            ps.bucketByLeaf();
            world->grid.rebuild(ps, 0);
            contacts.bind(world->grid, world->colliders.size(), false);
            compareAll(*world, contacts, reach);
        }
        const Vec3f leap(8.f * world->dx, 0.f, 0.f);
        for (int step = 0; step < 150; ++step) {
            for (Vec3f& x : ps.x) x += leap;
            ps.bucketByLeaf();
            world->grid.rebuild(ps, 0);
            contacts.bind(world->grid, world->colliders.size(), false);
        }
        // The wake is let go: 150 leaves' worth of blocks were bound, few are kept.
        INFO("stored " << contacts.storedLeaves() << ", blocks " << world->grid.blockCount());
        REQUIRE(contacts.storedLeaves() <=
                2 * world->grid.blockCount() + 256 + 64 * world->grid.blockCount());
        REQUIRE(contacts.storedLeaves() < 150 * world->grid.blockCount() / 2);
        for (Vec3f& x : ps.x) x -= 150.f * leap;
        ps.bucketByLeaf();
        world->grid.rebuild(ps, 0);
        contacts.bind(world->grid, world->colliders.size(), false);
        REQUIRE(compareAll(*world, contacts, reach) > 0);
        // The sticky walls' nodes (StickyWalls::fold): every node of a leaf (2D: its plane's)
        // classified once, on the first ask, listed in node order, and kept: the second pass
        // asks nothing and gets the same lists.
        const Collider& wall = world->colliders[0];
        const auto isOnWall = [&](const LeafKey& key, int n, NodeContacts::WallNode& node) {
            const Vec3f xn = nodePosition(key, n >> 6, (n >> 3) & 7, n & 7, world->dx, dim);
            const float phi = wall.signedDistance(xn);
            node.ghost = phi < -reach;
            node.mirror = xn - 2.f * phi * wall.normal(xn);
            return phi <= reach;
        };
        const int planeNodes = dim == 3 ? kLeafNodes : kLeafDim * kLeafDim;
        int asked = 0, ghosts = 0, held = 0;
        for (int pass = 0; pass < 2; ++pass)
            for (std::size_t b = 0; b < world->grid.blockCount(); ++b) {
                const LeafKey key = world->grid.blockKey(b);
                const auto& walls =
                    contacts.wallNodes(b, dim, [&](int n, NodeContacts::WallNode& node) {
                        ++asked;
                        REQUIRE((dim == 3 || (n & 7) == 0));
                        return isOnWall(key, n, node);
                    });
                std::size_t next = 0;
                for (int n = 0; n < kLeafNodes; n += dim == 3 ? 1 : kLeafDim) {
                    NodeContacts::WallNode expected;
                    if (!isOnWall(key, n, expected)) continue;
                    REQUIRE(next < walls.size());
                    REQUIRE(walls[next].node == n);
                    REQUIRE(walls[next].ghost == expected.ghost);
                    if (expected.ghost) REQUIRE(walls[next].mirror == expected.mirror);
                    ++(expected.ghost ? ghosts : held);
                    ++next;
                }
                REQUIRE(next == walls.size());
            }
        REQUIRE(asked == int(world->grid.blockCount()) * planeNodes);
        REQUIRE(ghosts > 0);
        REQUIRE(held > 0);
        REQUIRE(compareAll(*world, contacts, reach) > 0);
        // Another set of colliders: the store starts again.
        contacts.bind(world->grid, 1, false);
        world->colliders.resize(1);
        REQUIRE(compareAll(*world, contacts, reach) > 0);
    }
}
