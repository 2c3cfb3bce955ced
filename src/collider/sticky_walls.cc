#include <firn/sticky_walls.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>

namespace firn {

void StickyWalls::fold(const std::vector<Collider>& colliders, Grid& grid, NodeContacts& contacts,
                       float dx, int dim, bool flip, const Vec3f& gravityImpulse) {
    mState.clear();
    mGhosts.clear();
    std::vector<std::size_t> sticky; // indices into colliders
    for (std::size_t c = 0; c < colliders.size(); ++c)
        if (colliders[c].mirrorsInside()) sticky.push_back(c);
    if (sticky.empty()) return;

    // The nodes on or inside a wall, the ghosts of each block in node order, so that the list
    // (and the serial fold below) has the same order whatever the thread count. A node's side
    // of each wall depends on its position alone: the contact store keeps each leaf's wall
    // nodes across steps, and a step visits those with mass.
    const std::size_t nb = grid.blockCount();
    mState.assign(nb * kLeafNodes, kFree);
    std::vector<std::vector<Ghost>> ghostsOfBlock(nb);
    const float tolerance = kContactTolerance * dx;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nb, 1), [&](const auto& r) {
        for (std::size_t b = r.begin(); b != r.end(); ++b) {
            const LeafKey& key = grid.blockKey(b);
            const auto classify = [&](int n, NodeContacts::WallNode& node) {
                const Vec3f x = nodePosition(key, n >> 6, (n >> 3) & 7, n & 7, dx, dim);
                bool onWall = false;
                for (std::size_t c : sticky) {
                    const Collider& wall = colliders[c];
                    if (wall.clearOf(x, tolerance)) continue;
                    const float phi = wall.signedDistance(x);
                    if (phi > tolerance) continue;
                    if (phi >= -tolerance) { // on the surface: held at rest
                        node.ghost = false;
                        return true;
                    }
                    if (!onWall) { // inside: mirrored across the first wall it is in
                        onWall = node.ghost = true;
                        node.mirror = x - 2.f * phi * wall.normal(x);
                    }
                }
                return onWall;
            };
            const float* mass = grid.mass(b);
            for (const NodeContacts::WallNode& node : contacts.wallNodes(b, dim, classify)) {
                if (mass[node.node] <= 0.f) continue;
                mState[b * kLeafNodes + node.node] = node.ghost ? kGhost : kHeld;
                if (!node.ghost) continue;
                Ghost g{};
                g.at = {std::int32_t(b), node.node};
                g.mirrorPoint = node.mirror;
                ghostsOfBlock[b].push_back(g);
            }
        }
    });
    for (auto& list : ghostsOfBlock) mGhosts.insert(mGhosts.end(), list.begin(), list.end());
    if (mGhosts.empty()) return;

    // Multilinear weights of each mirror point among the free nodes with mass around it.
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, mGhosts.size(), 256), [&](const auto& r) {
        for (std::size_t q = r.begin(); q != r.end(); ++q) {
            Ghost& g = mGhosts[q];
            int base[3] = {0, 0, 0};
            float frac[3] = {0.f, 0.f, 0.f};
            for (int a = 0; a < dim; ++a) {
                const float s = g.mirrorPoint[a] / dx;
                base[a] = int(std::floor(s));
                frac[a] = s - float(base[a]);
            }
            for (int o = 0; o < (1 << dim); ++o) {
                float w = 1.f;
                int node[3] = {0, 0, 0};
                for (int a = 0; a < dim; ++a) {
                    const int bit = (o >> a) & 1;
                    node[a] = base[a] + bit;
                    w *= bit ? frac[a] : 1.f - frac[a];
                }
                if (w <= 0.f) continue;
                // Floor division by the leaf size (node indices may be negative).
                const LeafKey key = {node[0] >> kLeafLog2, node[1] >> kLeafLog2,
                                     node[2] >> kLeafLog2};
                const std::int32_t b = grid.blockOf(key);
                if (b < 0) continue;
                const int n = ((node[0] & (kLeafDim - 1)) << 6) |
                              ((node[1] & (kLeafDim - 1)) << 3) | (node[2] & (kLeafDim - 1));
                if (mState[std::size_t(b) * kLeafNodes + std::size_t(n)] != kFree ||
                    grid.mass(std::size_t(b))[n] <= 0.f)
                    continue;
                g.targets[g.count] = {b, n};
                g.weights[g.count] = w;
                ++g.count;
            }
        }
    });

    // A ghost without a free node around its mirror is held at rest by the update, as before.
    std::size_t kept = 0;
    for (const Ghost& g : mGhosts) {
        if (g.count == 0) {
            mState[std::size_t(g.at.block) * kLeafNodes + std::size_t(g.at.node)] = kHeld;
            continue;
        }
        mGhosts[kept++] = g;
    }
    mGhosts.resize(kept);

    // The FLIP impulse (the lower field's, with a slip surface) is channel 0 of the aux channels.
    const int auxStride = grid.auxChannels();
    // The fold. Row-sum lumping of T^T M T gives the mirror node w s m_g of mass (s = sum of the
    // ghost's weights); T^T gives it -w of the ghost's momentum and stress impulse; gravity's
    // load T^T M g is (m_j - sum w m_g) g, while the update will add dt g to the folded mass's
    // velocity: the difference, -w (1 + s) m_g dt g, goes with the forces (the FLIP impulse, or
    // the combined momentum and impulse of APIC and PIC). Targets are shared between ghosts, so
    // each target block applies its contributions in ghost order, as a serial loop over the
    // ghosts would (bitwise), and the blocks run in parallel; ghosts are never targets, so every
    // ghost's own values are read unchanged.
    std::vector<std::uint32_t> first(nb + 1, 0);
    for (const Ghost& g : mGhosts)
        for (int t = 0; t < g.count; ++t) ++first[std::size_t(g.targets[t].block) + 1];
    for (std::size_t b = 0; b < nb; ++b) first[b + 1] += first[b];
    std::vector<std::uint32_t> contributions(first[nb]); // ghost * 8 + target, by target block
    std::vector<std::uint32_t> cursor(first.begin(), first.end() - 1);
    for (std::size_t q = 0; q < mGhosts.size(); ++q)
        for (int t = 0; t < mGhosts[q].count; ++t)
            contributions[cursor[std::size_t(mGhosts[q].targets[t].block)]++] =
                std::uint32_t(q * 8 + std::size_t(t));
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nb, 16), [&](const auto& r) {
        for (std::size_t tb = r.begin(); tb != r.end(); ++tb)
            for (std::uint32_t k = first[tb]; k < first[tb + 1]; ++k) {
                const Ghost& g = mGhosts[contributions[k] / 8];
                const int t = int(contributions[k] % 8);
                float s = 0.f;
                for (int u = 0; u < g.count; ++u) s += g.weights[u];
                const std::size_t gb = std::size_t(g.at.block);
                const float mg = grid.mass(gb)[g.at.node];
                const float* momG = grid.velocity(gb) + 3 * g.at.node;
                const float* impG = flip ? grid.aux(gb) + auxStride * g.at.node : nullptr;
                const float w = g.weights[t];
                const int tn = g.targets[t].node;
                grid.mass(tb)[tn] += w * s * mg;
                float* mom = grid.velocity(tb) + 3 * tn;
                float* force = flip ? grid.aux(tb) + auxStride * tn : mom;
                for (int c = 0; c < 3; ++c) {
                    mom[c] -= w * momG[c];
                    if (flip) force[c] -= w * impG[c];
                    force[c] -= w * (1.f + s) * mg * gravityImpulse[c];
                }
            }
    });
}

void StickyWalls::mirror(Grid& grid, bool flip) const {
    const int auxStride = grid.auxChannels();
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, mGhosts.size(), 256), [&](const auto& r) {
        for (std::size_t q = r.begin(); q != r.end(); ++q) {
            const Ghost& g = mGhosts[q];
            Vec3f v = Vec3f::Zero(), reference = Vec3f::Zero();
            for (int t = 0; t < g.count; ++t) {
                const std::size_t tb = std::size_t(g.targets[t].block);
                const int tn = g.targets[t].node;
                const float* vt = grid.velocity(tb) + 3 * tn;
                v -= g.weights[t] * Vec3f(vt[0], vt[1], vt[2]);
                if (flip) {
                    const float* at = grid.aux(tb) + auxStride * tn;
                    reference -= g.weights[t] * Vec3f(at[0], at[1], at[2]);
                }
            }
            const std::size_t gb = std::size_t(g.at.block);
            float* out = grid.velocity(gb) + 3 * g.at.node;
            for (int c = 0; c < 3; ++c) out[c] = v[c];
            if (flip) {
                float* ref = grid.aux(gb) + auxStride * g.at.node;
                for (int c = 0; c < 3; ++c) ref[c] = reference[c];
            }
        }
    });
}

} // namespace firn
