"""The printed-link collision model in the page's JavaScript, for a live verdict.

``handarm._collide`` (numba) is the model; this is the same computation for a pose that
does not move (``colliding_link_pairs``): per link pair, its groups of piece pairs, each
group's bounding pieces first, a bounding-sphere test before each pair. A browser test holds
the two against each other on random poses.
"""

from __future__ import annotations

__all__ = ["collision_data", "COLLISION_JS"]


def collision_data(design) -> dict:
    """What the JavaScript needs: lengths, pieces, clearance, piece pairs per link pair."""
    from handarm.collision import LINK_PAIRS, envelopes

    env = envelopes(design)
    return {
        "a": [float(v) for v in design.lengths],
        "c": float(env.clearance),
        "pi": env.pi.tolist(),
        "pf": env.pf.tolist(),
        "groups": env.groups.tolist(),
        "rows": env.rows.tolist(),
        "lp_groups": env.lp_groups.tolist(),
        "names": [f"l{a}–l{b}" for a, b in LINK_PAIRS],
    }


#: ``collidingPairs(E, q)``: names of the link pairs that collide at q (rad).
COLLISION_JS = r"""
function collidingPairs(E, q) {
  const a = E.a, c = E.c;
  const t1 = q[0], t2 = t1 + q[1], t3 = t2 + q[2];
  const c1 = Math.cos(t1), s1 = Math.sin(t1), c2 = Math.cos(t2), s2 = Math.sin(t2);
  const c3 = Math.cos(t3), s3 = Math.sin(t3);
  const j2x = a[1] * c1, j2y = a[1] * s1, j3x = j2x + a[2] * c2, j3y = j2y + a[2] * s2;
  const j4x = j3x + a[3] * c3, j4y = j3y + a[3] * s3;
  const a4 = q[3], a5 = a4 + q[4], a6 = a5 + q[5];
  const c4 = Math.cos(a4), s4 = Math.sin(a4), c5 = Math.cos(a5), s5 = Math.sin(a5);
  const c6 = Math.cos(a6), s6 = Math.sin(a6);
  const j5s = a[4] * c4, j5z = a[4] * s4, j6s = j5s + a[5] * c5, j6z = j5z + a[5] * s5;
  const slots = [[1, 0, 0, 0], [1, 0, 0, 0], [c1, s1, 0, 0], [c1, s1, j2x, j2y],
    [c2, s2, j2x, j2y], [c2, s2, j3x, j3y], [c3, s3, j3x, j3y], [1, 0, 0, 0],
    [c4, s4, 0, 0], [c4, s4, j5s, j5z], [c5, s5, j5s, j5z], [c5, s5, j6s, j6z],
    [c6, s6, j6s, j6z]];
  const dx = c3, dy = s3, fx = j4x, fy = j4y;
  const placed = E.pi.map((p, k) => {
    const f = E.pf[k], sl = slots[p[0] === 6 ? 12 : 2 * p[0] + p[1]];
    const [cc, ss, ox, oy] = sl;
    const x0 = ox + cc * f[0] - ss * f[1], y0 = oy + ss * f[0] + cc * f[1];
    const x1 = ox + cc * f[2] - ss * f[3], y1 = oy + ss * f[2] + cc * f[3];
    const mx = 0.5 * (x0 + x1), my = 0.5 * (y0 + y1), mw = 0.5 * (f[5] + f[6]);
    const centre = p[2] === 0 ? [mx, my, mw] : [fx + mx * dx + mw * dy, fy + mx * dy - mw * dx, my];
    return [x0, y0, x1, y1, centre];
  });
  function apart(i, j) {
    const A = placed[i][4], B = placed[j][4], r = E.pf[i][7] + E.pf[j][7] + c;
    const ex = A[0] - B[0], ey = A[1] - B[1], ez = A[2] - B[2];
    return ex * ex + ey * ey + ez * ez > r * r;
  }
  function ps(px, py, ax, ay, bx, by) {
    const ex = bx - ax, ey = by - ay, den = ex * ex + ey * ey;
    let t = 0;
    if (den > 0) t = Math.min(1, Math.max(0, ((px - ax) * ex + (py - ay) * ey) / den));
    return Math.hypot(px - (ax + t * ex), py - (ay + t * ey));
  }
  function segDist(A, B) {
    const [a0x, a0y, a1x, a1y] = A, [b0x, b0y, b1x, b1y] = B;
    const d1 = (b1x - b0x) * (a0y - b0y) - (b1y - b0y) * (a0x - b0x);
    const d2 = (b1x - b0x) * (a1y - b0y) - (b1y - b0y) * (a1x - b0x);
    const d3 = (a1x - a0x) * (b0y - a0y) - (a1y - a0y) * (b0x - a0x);
    const d4 = (a1x - a0x) * (b1y - a0y) - (a1y - a0y) * (b1x - a0x);
    if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0)))
      return 0;
    return Math.min(ps(a0x, a0y, b0x, b0y, b1x, b1y), ps(a1x, a1y, b0x, b0y, b1x, b1y),
                    ps(b0x, b0y, a0x, a0y, a1x, a1y), ps(b1x, b1y, a0x, a0y, a1x, a1y));
  }
  function clip(s0, w0, s1, w1, lo, hi) {
    let ta = 0, tb = 1;
    const dw = w1 - w0;
    if (dw === 0) { if (w0 < lo || w0 > hi) return [Infinity, -Infinity]; }
    else {
      let u0 = (lo - w0) / dw, u1 = (hi - w0) / dw;
      if (u0 > u1) [u0, u1] = [u1, u0];
      ta = Math.max(ta, u0); tb = Math.min(tb, u1);
      if (ta > tb) return [Infinity, -Infinity];
    }
    const sa = s0 + ta * (s1 - s0), sb = s0 + tb * (s1 - s0);
    return [Math.min(sa, sb), Math.max(sa, sb)];
  }
  function cross(b, fb, t, ft) {  // base piece b against tip piece t
    const rb = fb[4], rt = ft[4];
    const s0 = (b[0] - fx) * dx + (b[1] - fy) * dy, u0 = -(b[0] - fx) * dy + (b[1] - fy) * dx;
    const s1 = (b[2] - fx) * dx + (b[3] - fy) * dy, u1 = -(b[2] - fx) * dy + (b[3] - fy) * dx;
    let [lo, hi] = clip(s0, u0, s1, u1, -ft[6] - rb - c, -ft[5] + rb + c);
    if (lo > hi) return false;
    const blo = lo - rb - 0.5 * c, bhi = hi + rb + 0.5 * c;
    [lo, hi] = clip(t[0], t[1], t[2], t[3], fb[5] - rt - c, fb[6] + rt + c);
    if (lo > hi) return false;
    const tlo = lo - rt - 0.5 * c, thi = hi + rt + 0.5 * c;
    return blo <= bhi && tlo <= thi && blo <= thi && tlo <= bhi;
  }
  function collide(i, j) {
    const pa = E.pi[i][2], pb = E.pi[j][2], fa = E.pf[i], fb = E.pf[j];
    if (pa === pb) return segDist(placed[i], placed[j]) < fa[4] + fb[4] + c;
    return pa === 0 ? cross(placed[i], fa, placed[j], fb) : cross(placed[j], fb, placed[i], fa);
  }
  function groupHit(g) {
    const [b0, b1, start, stop] = E.groups[g];
    if (apart(b0, b1) || !collide(b0, b1)) return false;
    if (start === stop) return true;  // the group is the pair of its bounding pieces
    for (let r = start; r < stop; r++) {
      const [i, j] = E.rows[r];
      if (!apart(i, j) && collide(i, j)) return true;
    }
    return false;
  }
  return E.names.filter((name, lp) => {
    for (let g = E.lp_groups[lp][0]; g < E.lp_groups[lp][1]; g++) if (groupHit(g)) return true;
    return false;
  });
}
"""
