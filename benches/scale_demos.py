#!/usr/bin/env python3
"""Synthetic positioning demonstrations for the scale benchmark (issue 36), as CSV on stdout.

    python3 benches/scale_demos.py POINTS > demos.csv

Episodes of 1,000 points: from the origin to a goal drawn from the positioning domain's ranges,
steered by a proportional controller with a little noise, 20 ms steps, values rounded to 1e-4
(the same controller as benches/scale.rs, with Python's own random numbers, seed 1).
"""
import math
import random
import sys

EPISODE = 1000


def wrap(a):
    return a - math.tau * math.floor((a + math.pi) / math.tau)


def main():
    points = int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000
    rng = random.Random(1)
    out = sys.stdout
    out.write("episode,t,dist2,bearing,dheading,trans,rot\n")
    for e in range((points + EPISODE - 1) // EPISODE):
        xg, yg, thg = rng.uniform(-0.33, 4.5), rng.uniform(-4.0, 0.17), rng.uniform(-3.1, 1.1)
        x = y = th = 0.0
        rows = []
        for k in range(EPISODE):
            dx, dy = xg - x, yg - y
            dist2 = dx * dx + dy * dy
            bearing = 0.0 if dx == 0 and dy == 0 else wrap(math.atan2(dy, dx) - th)
            dheading = wrap(thg - th)
            dist = math.sqrt(dist2)
            trans = min(1.0, max(-1.0, 0.6 * dist * math.cos(bearing) + rng.uniform(-0.01, 0.01)))
            steer = bearing if dist > 0.3 else dheading
            rot = min(1.0, max(-1.0, 1.2 * steer + rng.uniform(-0.01, 0.01)))
            rows.append("e%d,%.4g,%.4f,%.4f,%.4f,%.4f,%.4f" % (e, k * 0.02, dist2, bearing, dheading, trans, rot))
            th = wrap(th + rot * 0.02)
            x += trans * math.cos(th) * 0.02
            y += trans * math.sin(th) * 0.02
        out.write("\n".join(rows))
        out.write("\n")


if __name__ == "__main__":
    main()
