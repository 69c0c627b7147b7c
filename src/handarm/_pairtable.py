"""Numba kernels of the joint-space tables of the printed-link model (``handarm.collision``).

A link pair two links apart, (l_k, l_k+2), meets or not according to the two joints between
them alone: its model status is a function of (q_k+1, q_k+2) (array indices k, k + 1). A
*pair table* is a quadtree over the rectangle of those two joints' limits whose leaves are
certified:

* FREE: the model finds no contact of the pair anywhere in the cell;
* HIT: it finds contact everywhere in the cell;
* MIXED: neither could be proven down to the tree's depth.

A cell is certified by the model's own test at its middle with the pieces grown (FREE) or
shrunk (HIT) by how far they can move while the joints stay in the cell, with a frame held
still that keeps every piece in its own plane (the model grows a piece within its plane
only): l_k for (l0, l2), (l3, l5), (l4, l6), whose far link turns about axles square to
its plane; l3 for (l1, l3), l1 then turning about joints 3 and 2; l3 for (l2, l4), l2
turning about joint 3 and l4 about joint 4. A point at distance r from an axle moves at
most r times the turn (``handarm.collision.pair_tables`` gives each piece's
coefficients). The test is the one ``handarm._collide.groups_status`` applies over a
stretch of the IK, so a leaf's claim holds for the model at every configuration of its
cell.

``query_box`` answers for a box of joint angles: FREE if every leaf it meets is FREE, HIT if
every one is HIT, else UNSURE (a MIXED leaf, both kinds, or a box outside the table). The
IK asks it for the joint angles a stretch of its line can take (``handarm.ik._printed``).

Nodes are one int32 array: a value >= 0 is the index of the first of a node's four
children (stored together: x low/y low, x high/y low, x low/y high, x high/y high), -1 a
FREE leaf, -2 a HIT leaf, -3 a MIXED leaf.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from handarm._collide import REL, groups_status, new_pose, place_frames, place_piece, scratch

JIT = {"cache": True, "nogil": True, "fastmath": False, "error_model": "numpy"}

FREE, HIT, UNSURE = 0, 1, 2
_LEAF_FREE, _LEAF_HIT, _LEAF_MIXED = -1, -2, -3
#: Largest stack of ``query_box`` (three siblings wait per level, 16 levels).
QUERY_STACK = 64


@nb.njit(**JIT)
def cell_status(q, a, pieces, ci, cj, di, dj, pi, pf, groups, rows, mask, c, sc):
    """The model's status of one link pair over a cell of two joints' angles.

    q (6,): the cell's middle (the other joints anywhere); ``pieces``: the pair's pieces
    (bounding pieces included), each moving at most ``di * ci + dj * cj`` while the two
    joints stay within ``di``, ``dj`` (rad) of the middle; ``mask``: the pair's groups.
    The pieces are placed and grown here, then judged by the model's own group test
    (``handarm._collide.groups_status``, which finds them placed). Returns FREE, HIT or
    UNSURE (for MIXED).
    """
    frames, xy, stamp, coef, motion = sc
    place_frames(q, a, 0.0, frames)
    new_pose(stamp)
    now = stamp[stamp.shape[0] - 1]
    for n in range(pieces.shape[0]):
        k = pieces[n]
        place_piece(k, frames, pi, pf, xy)
        grow = (di * ci[n] + dj * cj[n]) * (1.0 + 1e-12)
        xy[k, 7], xy[k, 8], xy[k, REL] = grow, 0.0, grow  # no slide; l3 holds still
        stamp[k] = now
    motion[0] = 0.0  # moving: the grown and shrunk tests (the grows are set above)
    hit, unsure = groups_status(mask, frames, stamp, xy, pi, pf, groups, rows, coef, motion, c)
    if hit:
        return HIT
    return UNSURE if unsure else FREE


@nb.njit(**JIT)
def build_table(
    ji, x0, x1, y0, y1, a, pieces, ci, cj, pi, pf, groups, rows, mask, c, cell, max_nodes
):
    """The quadtree of one pair over joints (ji, ji + 1) in [x0, x1] x [y0, y1] (rad).

    ``mask``: the pair's groups, bit g for group g.
    Cells are halved down to ``cell`` (rad) on each side; a MIXED cell that size is a leaf.
    Returns the nodes (see module doc), or an array of one MIXED leaf if ``max_nodes`` would
    be exceeded (the table then proves nothing and costs nothing).
    """
    nodes = np.empty(max_nodes, np.int32)
    # the cells waiting to be certified: node index, bounds
    todo_n = np.empty(max_nodes, np.int64)
    todo_b = np.empty((max_nodes, 4))
    sc = scratch(pi.shape[0])
    q = np.zeros(6)
    n_nodes = 1
    head, tail = 0, 1
    todo_n[0] = 0
    todo_b[0, 0], todo_b[0, 1], todo_b[0, 2], todo_b[0, 3] = x0, x1, y0, y1
    while head < tail:
        node = todo_n[head]
        bx0, bx1, by0, by1 = todo_b[head, 0], todo_b[head, 1], todo_b[head, 2], todo_b[head, 3]
        head += 1
        q[ji] = 0.5 * (bx0 + bx1)
        q[ji + 1] = 0.5 * (by0 + by1)
        di, dj = 0.5 * (bx1 - bx0), 0.5 * (by1 - by0)
        s = cell_status(q, a, pieces, ci, cj, di, dj, pi, pf, groups, rows, mask, c, sc)
        if s == FREE:
            nodes[node] = _LEAF_FREE
            continue
        if s == HIT:
            nodes[node] = _LEAF_HIT
            continue
        if max(bx1 - bx0, by1 - by0) <= cell:
            nodes[node] = _LEAF_MIXED
            continue
        if n_nodes + 4 > max_nodes or tail + 4 > max_nodes:
            out = np.empty(1, np.int32)
            out[0] = _LEAF_MIXED
            return out
        nodes[node] = n_nodes
        mx, my = 0.5 * (bx0 + bx1), 0.5 * (by0 + by1)
        for k in range(4):
            todo_n[tail] = n_nodes + k
            todo_b[tail, 0] = bx0 if k % 2 == 0 else mx
            todo_b[tail, 1] = mx if k % 2 == 0 else bx1
            todo_b[tail, 2] = by0 if k < 2 else my
            todo_b[tail, 3] = my if k < 2 else by1
            tail += 1
        n_nodes += 4
    return _collapsed(nodes[:n_nodes])


@nb.njit(**JIT)
def _collapsed(nodes):
    """The tree with every node whose four children are leaves of one kind made that leaf.

    A cell made of four FREE cells is FREE (every configuration of it lies in one of them),
    likewise HIT; children come after their parent (the tree is built breadth first), so one
    pass from the end merges whole subtrees. ``query_box`` then stops at the merged leaf
    instead of visiting every small leaf of a region the model decided cell by cell. The
    merged nodes' children stay in the array, unreachable.
    """
    out = nodes.copy()
    for node in range(out.shape[0] - 1, -1, -1):
        v = out[node]
        if v < 0:
            continue
        kind = out[v]
        if kind != _LEAF_FREE and kind != _LEAF_HIT:
            continue
        if out[v + 1] == kind and out[v + 2] == kind and out[v + 3] == kind:
            out[node] = kind
    return out


@nb.njit(**JIT)
def query_box(nodes, off, dom, bx0, bx1, by0, by1, stack, bounds):
    """FREE, HIT or UNSURE for joint angles in [bx0, bx1] x [by0, by1] (see module doc).

    ``nodes[off:]`` is the table, ``dom`` its (x0, x1, y0, y1); ``stack`` (QUERY_STACK,)
    int64 and ``bounds`` (QUERY_STACK, 4) scratch. A box reaching outside the table is
    UNSURE.
    """
    x0, x1, y0, y1 = dom[0], dom[1], dom[2], dom[3]
    if bx0 < x0 or bx1 > x1 or by0 < y0 or by1 > y1:
        return UNSURE
    seen_free, seen_hit = False, False
    stack[0] = 0
    bounds[0, 0], bounds[0, 1], bounds[0, 2], bounds[0, 3] = x0, x1, y0, y1
    top = 1
    while top > 0:
        top -= 1
        node = stack[top]
        nx0, nx1, ny0, ny1 = bounds[top, 0], bounds[top, 1], bounds[top, 2], bounds[top, 3]
        v = nodes[off + node]
        if v == _LEAF_FREE:
            seen_free = True
        elif v == _LEAF_HIT:
            seen_hit = True
        elif v == _LEAF_MIXED:
            return UNSURE
        else:
            mx, my = 0.5 * (nx0 + nx1), 0.5 * (ny0 + ny1)
            for k in range(4):
                kx0 = nx0 if k % 2 == 0 else mx
                kx1 = mx if k % 2 == 0 else nx1
                ky0 = ny0 if k < 2 else my
                ky1 = my if k < 2 else ny1
                if kx1 < bx0 or kx0 > bx1 or ky1 < by0 or ky0 > by1:
                    continue
                if top >= stack.shape[0]:
                    return UNSURE
                stack[top] = v + k
                bounds[top, 0], bounds[top, 1], bounds[top, 2], bounds[top, 3] = kx0, kx1, ky0, ky1
                top += 1
        if seen_free and seen_hit:
            return UNSURE
    return FREE if not seen_hit else HIT
