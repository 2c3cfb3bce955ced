#include <firn/node_contacts.h>

#include <stdexcept>
#include <string>
#include <unordered_map>

namespace firn {

namespace {

struct LeafKeyHash {
    std::size_t operator()(const LeafKey& k) const {
        std::uint64_t h = std::uint32_t(k[0]);
        h = h * 0x9E3779B97F4A7C15ull ^ std::uint32_t(k[1]);
        h = h * 0x9E3779B97F4A7C15ull ^ std::uint32_t(k[2]);
        return std::size_t(h ^ (h >> 29));
    }
};

/// Records of leaves unused for this many re-bindings (new grid topologies: a steady grid keeps
/// its binding) are dropped once the store holds more than twice the grid's blocks: a flow's
/// wake is let go, a leaf the snow comes back to is asked again (the answers are the same).
constexpr std::uint64_t kKeepUnused = 64;

} // namespace

struct NodeContacts::Leaf {
    std::vector<std::uint16_t> states; ///< kLeafNodes x mSlots
    std::vector<Vec3f> normals;        ///< of the nodes in contact, in the order first asked
    std::vector<WallNode> walls;       ///< valid once wallsKnown
    bool wallsKnown = false;
    std::uint64_t lastBound = 0;
};

struct NodeContacts::Leaves {
    std::unordered_map<LeafKey, Leaf, LeafKeyHash> byKey; // node-based: leaves stay put
    std::uint64_t binds = 0;
};

NodeContacts::NodeContacts()
    : mLeaves(std::make_unique<Leaves>()) {}
NodeContacts::~NodeContacts() = default;
NodeContacts::NodeContacts(NodeContacts&&) noexcept = default;
NodeContacts& NodeContacts::operator=(NodeContacts&&) noexcept = default;

void NodeContacts::clear() {
    mLeaves->byKey.clear();
    mBlocks.clear();
    mStates.clear();
    mNormals.clear();
    mBoundTopology = 0;
}

std::size_t NodeContacts::storedLeaves() const {
    return mLeaves->byKey.size();
}

std::size_t NodeContacts::storedBytes() const {
    std::size_t bytes = 0;
    for (const auto& [key, leaf] : mLeaves->byKey)
        bytes += leaf.states.capacity() * sizeof(std::uint16_t) +
                 leaf.normals.capacity() * sizeof(Vec3f) + leaf.walls.capacity() * sizeof(WallNode);
    return bytes;
}

void NodeContacts::bind(const Grid& grid, std::size_t colliderCount, bool slipSurface) {
    const std::size_t slots = colliderCount + (slipSurface ? 1 : 0);
    if (slots > 127)
        throw std::runtime_error("too many colliders for the grid's contact store (" +
                                 std::to_string(colliderCount) + "; at most 126)");
    const std::size_t slipSlot = colliderCount;
    if (colliderCount != mColliderCount || slots != mSlots || slipSlot != mSlipSlot) clear();
    if (grid.topologyId() == mBoundTopology) return;
    mBoundTopology = grid.topologyId();
    mColliderCount = colliderCount;
    mSlots = slots;
    mSlipSlot = slipSlot;
    Leaves& leaves = *mLeaves;
    const std::uint64_t now = ++leaves.binds;
    const std::size_t blocks = grid.blockCount();
    mBlocks.resize(blocks);
    mStates.resize(blocks);
    mNormals.resize(blocks);
    for (std::size_t b = 0; b < blocks; ++b) {
        Leaf& leaf = leaves.byKey[grid.blockKey(b)];
        if (leaf.states.empty()) leaf.states.assign(kLeafNodes * slots, kUnknown);
        leaf.lastBound = now;
        mBlocks[b] = &leaf;
        mStates[b] = leaf.states.data();
        mNormals[b] = &leaf.normals;
    }
    if (leaves.byKey.size() <= 2 * blocks + 256) return;
    for (auto it = leaves.byKey.begin(); it != leaves.byKey.end();)
        it = it->second.lastBound + kKeepUnused < now ? leaves.byKey.erase(it) : std::next(it);
}

std::uint16_t& NodeContacts::state(std::size_t b, int n, std::size_t slot) {
    return mBlocks[b]->states[std::size_t(n) * mSlots + slot];
}

std::uint16_t NodeContacts::keep(std::size_t b, const Vec3f& normal) {
    std::vector<Vec3f>& normals = mBlocks[b]->normals;
    normals.push_back(normal);
    return std::uint16_t(kInContact + normals.size() - 1); // at most 512 x slots of them
}

const Vec3f& NodeContacts::normalOf(std::size_t b, std::uint16_t state) const {
    return mBlocks[b]->normals[state - kInContact];
}

std::optional<Vec3f> NodeContacts::firstContact(std::size_t b, int n, std::size_t c,
                                                const Collider& collider, const Vec3f& xn,
                                                float reach) {
    std::uint16_t& s = state(b, n, c);
    const bool within = !collider.clearOf(xn, reach) && collider.signedDistance(xn) <= reach;
    s = within ? keep(b, collider.normal(xn)) : std::uint16_t(kClear);
    if (s == kClear) return std::nullopt;
    return normalOf(b, s);
}

const std::vector<NodeContacts::WallNode>* NodeContacts::knownWalls(std::size_t b) const {
    const Leaf& leaf = *mBlocks[b];
    return leaf.wallsKnown ? &leaf.walls : nullptr;
}

const std::vector<NodeContacts::WallNode>& NodeContacts::keepWalls(std::size_t b,
                                                                   std::vector<WallNode>&& walls) {
    Leaf& leaf = *mBlocks[b];
    leaf.walls = std::move(walls);
    leaf.walls.shrink_to_fit();
    leaf.wallsKnown = true;
    return leaf.walls;
}

} // namespace firn
