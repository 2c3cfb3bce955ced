// Sticky (no-slip) colliders as a constraint on the grid's velocity field instead of zeroed nodes.
//
// Zeroing every node inside a sticky collider leaves the quadratic B-splines that straddle the
// wall without their partners: a velocity that grows linearly from the wall is seen by the
// particles in the first 1.5 cells with a gradient about 25 % too small, and the stress a node
// next to the wall feels includes a boundary term that belongs to the wall. Both are first-order
// errors in a layer 1.5 cells thick (V3's period, V4's base stress, validation.md).
//
// Here the nodes strictly inside a sticky collider ("ghosts") take the velocity of their mirror
// image across the surface, negated: v_g = -sum_j w_gj v_j, with w_gj the multilinear weights of
// the mirror point x_g + 2 d n among the free nodes j (nodes on the surface stay at rest). That is
// the boundary-modified B-spline basis N_j - sum_g w_gj N_g, which reproduces every linear field
// that vanishes on the wall. The grid equations are the Galerkin equations of that basis, with
// the constraint T (v_g = -w_g . v_free) folded in before the update: T^T M T lumped by rows for
// the mass, T^T for the momentum, the stress impulse and gravity. The mirror's weights are the
// fold's, so the system stays symmetric (no energy is made). On a plane through grid nodes the
// mirror of a node is a node and the fold is exact; elsewhere mirror corners that are themselves
// constrained drop out (they count as at rest).
#pragma once

#include <firn/collider.h>
#include <firn/grid.h>
#include <firn/node_contacts.h>

#include <cstdint>
#include <vector>

namespace firn {

class StickyWalls {
public:
    /// Classifies the nodes with mass against the sticky colliders among `colliders` (each
    /// leaf's wall nodes kept in `contacts`, bound to `grid`), and folds the ghosts' mass,
    /// momentum (Grid::velocity) and, for FLIP, stress impulse (Grid::aux) into their mirror
    /// nodes. `gravityImpulse` is dt g (ramped): the fold moves the ghosts' weight onto the
    /// mirror nodes with the constraint's sign. Call after P2G, before the update.
    void fold(const std::vector<Collider>& colliders, Grid& grid, NodeContacts& contacts, float dx,
              int dim, bool flip, const Vec3f& gravityImpulse);

    /// True for a ghost: a node inside a sticky collider whose mirror point has free nodes
    /// around it. The update skips it; mirror() sets it. Nodes on a sticky surface, and ghosts
    /// without a mirror, are not ghosts: the update holds them at rest as before. Valid after
    /// fold().
    bool isGhost(std::size_t block, int node) const {
        return !mState.empty() && mState[block * kLeafNodes + std::size_t(node)] == kGhost;
    }

    /// True for a node that a sticky collider holds at rest (on its surface, or inside
    /// without a mirror). The update skips the sticky colliders and zeroes these nodes.
    bool isHeld(std::size_t block, int node) const {
        return !mState.empty() && mState[block * kLeafNodes + std::size_t(node)] == kHeld;
    }

    /// After the update: every ghost takes the negated velocity at its mirror point (for FLIP
    /// also the negated reference velocity in Grid::aux, so that its FLIP increment mirrors too).
    void mirror(Grid& grid, bool flip) const;

private:
    enum : std::uint8_t { kFree = 0, kHeld = 1, kGhost = 2 };
    struct NodeRef {
        std::int32_t block;
        std::int32_t node;
    };
    struct Ghost {
        NodeRef at;
        Vec3f mirrorPoint;      ///< m
        NodeRef targets[8];     ///< free nodes around the mirror point
        float weights[8] = {0}; ///< their multilinear weights
        int count = 0;
    };
    std::vector<std::uint8_t> mState; ///< per node of the grid: kFree, kHeld or kGhost
    std::vector<Ghost> mGhosts;
};

} // namespace firn
