#include <firn/node_contacts.h>

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

/// Records of leaves unused for this many binds are dropped once the store holds more than
/// twice the grid's blocks: a flow's wake is let go, a leaf the snow comes back to is asked
/// again (the answers are the same).
constexpr std::uint64_t kKeepUnused = 64;

} // namespace

struct NodeContacts::Leaves {
    struct Leaf {
        std::vector<Record> records;
        std::uint64_t lastBound = 0;
    };
    std::unordered_map<LeafKey, Leaf, LeafKeyHash> byKey; // node-based: records stay put
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
}

std::size_t NodeContacts::storedLeaves() const {
    return mLeaves->byKey.size();
}

void NodeContacts::bind(const Grid& grid, std::size_t colliderCount) {
    if (colliderCount != mColliderCount) clear();
    mColliderCount = colliderCount;
    Leaves& leaves = *mLeaves;
    const std::uint64_t now = ++leaves.binds;
    const std::size_t blocks = grid.blockCount();
    mBlocks.resize(blocks);
    for (std::size_t b = 0; b < blocks; ++b) {
        Leaves::Leaf& leaf = leaves.byKey[grid.blockKey(b)];
        if (leaf.records.empty()) leaf.records.resize(kLeafNodes * (colliderCount + 1));
        leaf.lastBound = now;
        mBlocks[b] = leaf.records.data();
    }
    if (leaves.byKey.size() <= 2 * blocks + 256) return;
    for (auto it = leaves.byKey.begin(); it != leaves.byKey.end();)
        it = it->second.lastBound + kKeepUnused < now ? leaves.byKey.erase(it) : std::next(it);
}

const Vec3f* NodeContacts::contact(std::size_t b, int n, std::size_t c, const Collider& collider,
                                   const Vec3f& xn, float reach) {
    Record& r = record(b, n, c);
    if (r.state == kUnknown) {
        const bool within = !collider.clearOf(xn, reach) && collider.signedDistance(xn) <= reach;
        if (within) r.normal = collider.normal(xn);
        r.state = within ? kInContact : kClear;
    }
    return r.state == kInContact ? &r.normal : nullptr;
}

} // namespace firn
