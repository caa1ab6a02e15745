#!/usr/bin/env python3
"""Write a combed groom for the head, neck and shoulders of the full-head scenes
(scenes/long-hair-shoulders.toml, scenes/full-head-smooth.toml): strands combed back and
down over the bodies, as OBJ polylines on standard output (root first, metres, rounded
to 0.01 mm).

Each strand is grown from its root in steps of STEP: its direction turns by TURN per
step towards COMB (back) while the strand is on top of the head, towards FALL (down)
once it is behind it or below its widest line, and a point that comes within OFFSET of
a body is put back on the body's surface offset by OFFSET (radially for the ellipsoid
head, from the axis for the capsules), after which the direction is the step actually
taken. The strand therefore follows the scalp from the crown, leaves it where the head
curves away, and drapes over the neck and shoulders or hangs down the back: a combed
groom close to rest, which the scene's fit turns into Super-Helices and its sag-free start
holds under gravity.

Roots: a Fibonacci lattice on the unit sphere, kept within MAX_ANGLE of AXIS (the same
cap as a `[[grooms]]` region), mapped to the ellipsoid. Standard library only; the same
output on every run.

    python3 scripts/combed_groom.py > scenes/data/long-hair.obj
    python3 scripts/combed_groom.py --count 200 --length 0.3 --length-variation 0.15 \
        > scenes/data/smooth-head.obj
"""

import argparse
import math

RADII = (0.075, 0.095, 0.11)  # the head ellipsoid, centred at the origin
# capsules (start, end, radius): neck and shoulders, fixed in the world
CAPSULES = [
    ((0.0, -0.01, -0.22), (0.0, -0.01, -0.08), 0.05),
    ((-0.19, -0.02, -0.25), (0.19, -0.02, -0.25), 0.06),
]
COUNT = 150  # defaults: the long-hair groom (command-line options change them)
AXIS = (0.0, -0.4, 1.0)
MAX_ANGLE = math.radians(75.0)
COMB = (0.0, -1.0, -0.3)  # back over the crown ...
FALL = (0.0, -0.15, -1.0)  # ... then down, once behind or beside the head
LENGTH = 0.5
LENGTH_VARIATION = 0.1
STEP = 0.005
TURN = math.radians(6.0)  # most turn of the direction towards the comb per step
OFFSET = 0.004  # distance kept from the bodies (the contact radius is 2 mm)
LIFT = math.radians(12.0)  # the first step leaves the scalp at this angle


def add(a, b):
    return tuple(x + y for x, y in zip(a, b))


def sub(a, b):
    return tuple(x - y for x, y in zip(a, b))


def mul(a, s):
    return tuple(x * s for x in a)


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def norm(a):
    return math.sqrt(dot(a, a))


def unit(a):
    n = norm(a)
    return mul(a, 1.0 / n)


def ellipsoid_out(p):
    """p moved radially out to the ellipsoid grown by OFFSET, if inside it."""
    grown = [r + OFFSET for r in RADII]
    rho = math.sqrt(sum((x / r) ** 2 for x, r in zip(p, grown)))
    return mul(p, 1.0 / rho) if rho < 1.0 else p


def capsule_out(p, cap):
    a, b, r = cap
    ab = sub(b, a)
    t = max(0.0, min(1.0, dot(sub(p, a), ab) / dot(ab, ab)))
    c = add(a, mul(ab, t))
    d = sub(p, c)
    n = norm(d)
    if n >= r + OFFSET or n == 0.0:
        return p
    return add(c, mul(d, (r + OFFSET) / n))


def keep_out(p):
    for _ in range(3):
        p = ellipsoid_out(p)
        for cap in CAPSULES:
            p = capsule_out(p, cap)
    return p


def turn_towards(d, target, angle):
    """d turned towards target by at most angle (both unit)."""
    c = max(-1.0, min(1.0, dot(d, target)))
    between = math.acos(c)
    if between <= angle:
        return target
    # slerp
    s = math.sin(between)
    f = math.sin(between - angle) / s
    g = math.sin(angle) / s
    return unit(add(mul(d, f), mul(target, g)))


def roots():
    axis = unit(AXIS)
    golden = math.pi * (3.0 - math.sqrt(5.0))
    out = []
    n = 4000
    for i in range(n):
        z = 1.0 - 2.0 * (i + 0.5) / n
        r = math.sqrt(1.0 - z * z)
        u = (r * math.cos(golden * i), r * math.sin(golden * i), z)
        if math.acos(max(-1.0, min(1.0, dot(u, axis)))) <= MAX_ANGLE:
            out.append(u)
    # thin to COUNT evenly along the lattice order
    step = len(out) / COUNT
    return [out[int(k * step)] for k in range(COUNT)]


def strand(u, k):
    # the root on the ellipsoid along u, its outward normal
    rho = math.sqrt(sum((x / r) ** 2 for x, r in zip(u, RADII)))
    root = mul(u, 1.0 / rho)
    normal = unit(tuple(x / (r * r) for x, r in zip(root, RADII)))
    comb = unit(COMB)
    tangent = sub(comb, mul(normal, dot(comb, normal)))
    if norm(tangent) < 1e-6:
        tangent = (0.0, -1.0, 0.0)
    tangent = unit(tangent)
    d = unit(add(mul(tangent, math.cos(LIFT)), mul(normal, math.sin(LIFT))))
    # length varied by a fixed pseudo-random sequence (the golden ratio's multiples)
    frac = (k * 0.6180339887498949) % 1.0
    length = LENGTH * (1.0 + LENGTH_VARIATION * (2.0 * frac - 1.0))
    points = [root]
    p = root
    steps = int(round(length / STEP))
    fall = unit(FALL)
    for _ in range(steps):
        on_top = p[2] > 0.0 and p[1] > -0.06
        d = turn_towards(d, comb if on_top else fall, TURN)
        q = keep_out(add(p, mul(d, STEP)))
        taken = sub(q, p)
        # keep the step length (the projection shortens or lengthens it)
        q = add(p, mul(unit(taken), STEP))
        q = keep_out(q)
        d = unit(sub(q, p))
        points.append(q)
        p = q
    return points


def main():
    global COUNT, LENGTH, LENGTH_VARIATION
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--count", type=int, default=COUNT, help="number of strands")
    parser.add_argument("--length", type=float, default=LENGTH, help="mean length, m")
    parser.add_argument(
        "--length-variation",
        type=float,
        default=LENGTH_VARIATION,
        help="relative spread of the lengths (uniform, +-)",
    )
    args = parser.parse_args()
    if args.count < 1 or args.length <= 0.0 or not 0.0 <= args.length_variation < 1.0:
        parser.error("--count >= 1, --length > 0 and 0 <= --length-variation < 1")
    COUNT, LENGTH, LENGTH_VARIATION = args.count, args.length, args.length_variation
    curves = [strand(u, k) for k, u in enumerate(roots())]
    options = []
    if COUNT != 150:
        options.append(f"--count {COUNT}")
    if LENGTH != 0.5:
        options.append(f"--length {LENGTH:g}")
    if LENGTH_VARIATION != 0.1:
        options.append(f"--length-variation {LENGTH_VARIATION:g}")
    command = " ".join(["scripts/combed_groom.py"] + options)
    print(f"# {COUNT} strands combed back and down over the head, neck and shoulders of the")
    print(f"# full-head scenes, root first, metres; written by {command}")
    print(
        f"# ({LENGTH * 100:g} cm +- {LENGTH_VARIATION * 100:g} %, 5 mm steps, 4 mm off the bodies)."
    )
    index = 1
    lines = []
    for c in curves:
        for x, y, z in c:
            print(f"v {x:.5f} {y:.5f} {z:.5f}")
        lines.append(" ".join(str(index + i) for i in range(len(c))))
        index += len(c)
    for l in lines:
        print("l " + l)


if __name__ == "__main__":
    main()
