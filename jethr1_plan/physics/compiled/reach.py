"""Pelvis positions moved into the legs' reach, compiled: onto the intersection of the two reach balls, and
into each leg's joint limits (the searches' projection, ``optimisers.search.Evaluator.into_reach``).

Units: m, rad.
"""

from __future__ import annotations

import math

import numpy as np

from jethr1_plan.physics.compiled.jit import kernel

__all__ = ["into_leg", "into_reach", "into_reach_one", "pitch_bounds"]


@kernel(inline="always")
def _onto_ball(p0, p1, p2, c0, c1, c2, d, radius, o0, o1, o2):
    """P at distance ``d`` from centre c moved onto c's ball of ``radius``; and whether it lands
    within ``radius`` of the other centre o."""
    s = radius / d
    q0, q1, q2 = c0 + (p0 - c0) * s, c1 + (p1 - c1) * s, c2 + (p2 - c2) * s
    return (q0 - o0) ** 2 + (q1 - o1) ** 2 + (q2 - o2) ** 2 <= radius * radius, q0, q1, q2


@kernel(inline="always")
def _onto_circle(p0, p1, p2, a0, a1, a2, ra, b0, b1, b2, rb):
    """The nearest point to P of the circle where the spheres (centre a, radius ``ra``) and (b, ``rb``)
    meet; P where they do not meet or P lies on their axis."""
    e0, e1, e2 = b0 - a0, b1 - a1, b2 - a2
    h = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
    if h == 0.0 or h > ra + rb or h < abs(ra - rb):
        return p0, p1, p2
    e0, e1, e2 = e0 / h, e1 / h, e2 / h
    t0 = (h * h + ra * ra - rb * rb) / (2 * h)  # the circle's centre, from a along the axis
    m0, m1, m2 = a0 + t0 * e0, a1 + t0 * e1, a2 + t0 * e2
    rc = math.sqrt(max(ra * ra - t0 * t0, 0.0))
    t = (p0 - m0) * e0 + (p1 - m1) * e1 + (p2 - m2) * e2
    u0, u1, u2 = p0 - m0 - t * e0, p1 - m1 - t * e1, p2 - m2 - t * e2
    nu = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
    if nu == 0.0:
        return p0, p1, p2
    s = rc / nu
    return m0 + u0 * s, m1 + u1 * s, m2 + u2 * s


@kernel(inline="always")
def _balls_one(p0, p1, p2, a0, a1, a2, b0, b1, b2, radius):
    """P moved onto the nearest point of the intersection of the balls of ``radius`` around a and b."""
    da = math.sqrt((p0 - a0) ** 2 + (p1 - a1) ** 2 + (p2 - a2) ** 2)
    db = math.sqrt((p0 - b0) ** 2 + (p1 - b1) ** 2 + (p2 - b2) ** 2)
    if da <= radius and db <= radius:
        return p0, p1, p2
    if da > radius:  # onto the swing ball; done if that lands inside the support ball
        inside, q0, q1, q2 = _onto_ball(p0, p1, p2, a0, a1, a2, da, radius, b0, b1, b2)
        if inside:
            return q0, q1, q2
    if db > radius:  # onto the support ball; done if that lands inside the swing ball
        inside, q0, q1, q2 = _onto_ball(p0, p1, p2, b0, b1, b2, db, radius, a0, a1, a2)
        if inside:
            return q0, q1, q2
    # onto the circle where the two spheres meet (a hair inside both)
    return _onto_circle(p0, p1, p2, a0, a1, a2, radius * (1.0 - 1e-12), b0, b1, b2, radius * (1.0 - 1e-12))


@kernel(inline="always")
def pitch_bounds(c, shape, level, row):
    """The least and greatest pitch β [rad] of the hip–ankle line (its angle from the vertical towards
    the foot's +x) that keep the ankle and hip pitch within their limits, the hip at distance ``c`` [m]
    from the ankle (see :func:`into_leg`)."""
    a, b = shape[level, row, 6], shape[level, row, 7]
    cos_k = min(max((a * a + b * b - c * c) / (2 * a * b), -1.0), 1.0)
    knee = math.pi - math.acos(cos_k)
    alpha = math.asin(min(max(a * math.sqrt(1.0 - cos_k * cos_k) / c, -1.0), 1.0))
    lo = max(-shape[level, row, 9] - alpha, shape[level, row, 10] + knee - alpha)
    hi = min(-shape[level, row, 8] - alpha, shape[level, row, 11] + knee - alpha)
    return lo, hi


@kernel(inline="always")
def _into_wedge(p1, p2, c1, c2, slo, clo, shi, chi):
    """(y, z) of P turned into the roll wedge of a leg whose reach centre is c: the angle atan2(y − c1,
    z − c2) of the hip about the foot's x axis kept within [lo, hi] (given by sine and cosine): the
    nearest point of the wedge, a convex cone about the line through c along x."""
    v1, v2 = p1 - c1, p2 - c2
    if v1 * chi - v2 * shi > 0.0:  # beyond hi: onto its ray (or the edge line)
        t = max(v1 * shi + v2 * chi, 0.0)
        return False, c1 + t * shi, c2 + t * chi
    if v1 * clo - v2 * slo < 0.0:  # beyond lo
        t = max(v1 * slo + v2 * clo, 0.0)
        return False, c1 + t * slo, c2 + t * clo
    return True, p1, p2


@kernel(inline="always")
def _into_pitch(p0, p1, p2, o0, o1, o2, sh, level, row):
    """P turned about o (its distance and roll kept) so that the pitch β lies within pitch_bounds."""
    if sh[level, row, 12] == -np.inf:  # no pitch limits
        return True, p0, p1, p2
    r0, r1, r2 = p0 - o0, p1 - o1, p2 - o2
    g = math.sqrt(r1 * r1 + r2 * r2)
    if r2 > 0.0 and r0 >= sh[level, row, 12] * g and r0 <= sh[level, row, 13] * g:  # within every c's pitch range
        return True, p0, p1, p2
    c = math.sqrt(g * g + r0 * r0)
    if g == 0.0 or c < sh[level, row, 4] * (1 - 1e-9) or c > sh[level, row, 5] * (1 + 1e-9):
        return False, p0, p1, p2
    beta = math.atan2(r0, g if r2 >= 0.0 else -g)
    lo, hi = pitch_bounds(c, sh, level, row)
    if beta >= lo and beta <= hi:
        return True, p0, p1, p2
    if lo > hi:
        return False, p0, p1, p2
    beta = min(max(beta, lo), hi)
    s = c * math.cos(beta) / g
    return False, o0 + c * math.sin(beta), o1 + r1 * s, o2 + r2 * s


@kernel(inline="always")
def into_leg(p0, p1, p2, o0, o1, o2, n0, n1, n2, radius, sh, level, row):
    """P moved into the hip positions from which one leg reaches within its joint limits (the trunk
    level, the sole flat and facing +x), o the centre of its reach ball, n the other leg's (whose ball of
    ``radius`` P should stay in); returns (whether P was inside, P).

    Seen from o, the hip at r = P − o has distance c = |r|, roll φ = atan2(r_y, r_z) about the foot's x
    axis and pitch β = atan2(r_x, √(r_y² + r_z²)). With the trunk level and the sole flat the knee depends
    on c alone, the ankle roll is φ and the hip roll −φ, and the ankle and hip pitch bound β within a
    range that depends on c (``leg_ik``): the set is a box in (c, φ, β). A point outside is moved onto
    the wedge of φ (the nearest point), then out onto the sphere of the least c (onto its circle with the
    other ball where that leaves it), then turned to the nearest β:
    continuous, so the searches can slide along a joint limit rather than stall against its penalty.

    ``sh[level, row]`` (14,): sin and cos of the least and greatest φ; the least and greatest c [m];
    thigh, shank [m]; the ankle pitch's and the hip pitch's limits [rad]; tan of a pitch range inside
    every c's (the fast path; −inf, inf: β free); all pulled in by 1e-9 so a moved point's joints land
    inside their limits despite rounding. The trunk's yaw does not enter: it sets the hip yaw alone.
    """
    inside, p1, p2 = _into_wedge(p1, p2, o1, o2, sh[level, row, 0], sh[level, row, 1], sh[level, row, 2],
                                 sh[level, row, 3])
    rmin = sh[level, row, 4]
    d2 = (p0 - o0) ** 2 + (p1 - o1) ** 2 + (p2 - o2) ** 2
    if d2 < rmin * rmin and d2 > 0.0:  # the knee beyond its bend: out onto the inner sphere
        s = rmin / math.sqrt(d2)
        p0, p1, p2, inside = o0 + (p0 - o0) * s, o1 + (p1 - o1) * s, o2 + (p2 - o2) * s, False
        if (p0 - n0) ** 2 + (p1 - n1) ** 2 + (p2 - n2) ** 2 > radius * radius:
            p0, p1, p2 = _onto_circle(p0, p1, p2, o0, o1, o2, rmin, n0, n1, n2, radius * (1.0 - 1e-12))
    ok, p0, p1, p2 = _into_pitch(p0, p1, p2, o0, o1, o2, sh, level, row)
    inside &= ok
    return inside, p0, p1, p2


@kernel(inline="always")
def _inside_fast(r0, r1, r2, radius, sh, level, row):
    """Whether the hip at r [m] from a leg's reach centre lies well inside the set of :func:`into_leg`
    (False: it may still, the exact test decides), without a square root where the leg has no pitch
    limits."""
    d2 = r0 * r0 + r1 * r1 + r2 * r2
    # without branches (``&``, not ``and``): 3.5 ns a point against 23 ns with short-circuits (measured)
    ok = ((d2 <= radius * radius) & (d2 >= sh[level, row, 4] * sh[level, row, 4]) & (r2 > 0.0)
          & (r1 * sh[level, row, 3] - r2 * sh[level, row, 2] <= 0.0)
          & (r1 * sh[level, row, 1] - r2 * sh[level, row, 0] >= 0.0))
    if sh[level, row, 12] == -np.inf:
        return ok
    g = math.sqrt(r1 * r1 + r2 * r2)
    return ok & (r0 >= sh[level, row, 12] * g) & (r0 <= sh[level, row, 13] * g)


@kernel(inline="always")
def into_reach_one(p0, p1, p2, c, centre_w, centre_s, radius, shapes, level):
    """One point of :func:`into_reach` for cell ``c``."""
    a0, a1, a2 = centre_w[c, 0], centre_w[c, 1], centre_w[c, 2]
    b0, b1, b2 = centre_s[c, 0], centre_s[c, 1], centre_s[c, 2]
    if level == 0:
        return _balls_one(p0, p1, p2, a0, a1, a2, b0, b1, b2, radius)
    if (_inside_fast(p0 - a0, p1 - a1, p2 - a2, radius, shapes, level, 0)
            & _inside_fast(p0 - b0, p1 - b1, p2 - b2, radius, shapes, level, 1)):
        return p0, p1, p2
    return _into_sets(p0, p1, p2, a0, a1, a2, b0, b1, b2, radius, shapes, level)


@kernel
def _into_sets(p0, p1, p2, a0, a1, a2, b0, b1, b2, radius, shapes, level):
    """:func:`into_reach_one` where the fast test fails: alternating moves into the balls and each leg's set."""
    for _ in range(4):
        p0, p1, p2 = _balls_one(p0, p1, p2, a0, a1, a2, b0, b1, b2, radius)
        ok_w, p0, p1, p2 = into_leg(p0, p1, p2, a0, a1, a2, b0, b1, b2, radius, shapes, level, 0)
        ok_s, p0, p1, p2 = into_leg(p0, p1, p2, b0, b1, b2, a0, a1, a2, radius, shapes, level, 1)
        if ok_w and ok_s:
            return p0, p1, p2
    # no point of all the sets found: within both balls at least (beyond a joint limit, not out of reach)
    return _balls_one(p0, p1, p2, a0, a1, a2, b0, b1, b2, radius)


@kernel
def into_reach(P, idx, centre_w, centre_s, radius, shapes, level):
    """P (M, 3) [m] projected onto the intersection of the two legs' reach balls (radius ``radius``
    [m] around the cells' swing and support centres, rows ``idx``): the nearest point from which both
    legs reach. Points already inside are unchanged; where the balls do not meet, P is returned.
    ``level`` > 0: then also into each leg's joint limits by :func:`into_leg` with the sets
    ``shapes[level]`` (row 0 the swing leg's, row 1 the support leg's; ``search.leg_shapes``),
    alternating up to four times; a point for which that does not settle is left in the balls only.
    A new array.
    """
    out = np.empty_like(P)
    for j in range(len(idx)):
        out[j, 0], out[j, 1], out[j, 2] = into_reach_one(P[j, 0], P[j, 1], P[j, 2], idx[j], centre_w, centre_s,
                                                          radius, shapes, level)
    return out
