"""ASCII STL models for make_corpus.sh and make_samples.sh (no downloads): boxes, cylinders,
shapes with bridges and overhangs (an arch, a box with a window, a flared hull), and a
small Benchy-like boat with curved perimeters (benchy_like).

    python3 corpus_models.py OUT_DIR [NAME ...]      (default: every model)
Every solid is closed and outward-oriented, centred on (0, 0), standing on z = 0."""
import math
import sys


def _facet(f, a, b, c):
    u = [b[i] - a[i] for i in range(3)]
    v = [c[i] - a[i] for i in range(3)]
    n = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
    l = math.sqrt(sum(x * x for x in n)) or 1.0
    f.write(" facet normal %g %g %g\n  outer loop\n" % tuple(x / l for x in n))
    for p in (a, b, c):
        f.write("   vertex %.6f %.6f %.6f\n" % p)
    f.write("  endloop\n endfacet\n")


def _write(path, name, tris):
    with open(path, "w") as f:
        f.write(f"solid {name}\n")
        for t in tris:
            _facet(f, *t)
        f.write(f"endsolid {name}\n")


def _area2(poly):
    return sum(poly[i - 1][0] * poly[i][1] - poly[i][0] * poly[i - 1][1] for i in range(len(poly)))


def _ear_clip(poly):
    """Triangles (index triples, counter-clockwise) of a simple counter-clockwise polygon."""
    idx = list(range(len(poly)))
    out = []

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    while len(idx) > 3:
        for k in range(len(idx)):
            i, j, m = idx[k - 1], idx[k], idx[(k + 1) % len(idx)]
            a, b, c = poly[i], poly[j], poly[m]
            if cross(a, b, c) <= 1e-12:
                continue                    # reflex or flat vertex: not an ear
            if any(cross(a, b, poly[q]) > 0 and cross(b, c, poly[q]) > 0 and cross(c, a, poly[q]) > 0
                   for q in idx if q not in (i, j, m)):
                continue
            out.append((i, j, m))
            idx.pop(k)
            break
        else:
            raise ValueError("polygon is not simple")
    out.append(tuple(idx))
    return out


def extrude_xz(profile, depth_d):
    """Prism: a simple polygon in the XZ plane (counter-clockwise seen from -Y) swept along Y."""
    if _area2(profile) < 0:
        profile = profile[::-1]
    y0, y1 = -depth_d / 2, depth_d / 2
    tris = []
    for i, j, m in _ear_clip(profile):
        p = [profile[q] for q in (i, j, m)]
        # polygon CCW in (x, z) seen from -Y: front cap normal -Y keeps that order
        tris.append(tuple((x, y0, z) for x, z in p))
        tris.append(tuple((x, y1, z) for x, z in p[::-1]))
    n = len(profile)
    for i in range(n):
        (ax, az), (bx, bz) = profile[i], profile[(i + 1) % n]
        tris.append(((ax, y0, az), (bx, y1, bz), (bx, y0, bz)))
        tris.append(((ax, y0, az), (ax, y1, az), (bx, y1, bz)))
    return tris


def box(sx, sy, sz):
    return extrude_xz([(-sx / 2, 0), (sx / 2, 0), (sx / 2, sz), (-sx / 2, sz)], sy)


def loft(rings):
    """Closed solid through horizontal rings [(z, [(x, y), ...] counter-clockwise)], same count each."""
    tris = []
    for (za, ra), (zb, rb) in zip(rings, rings[1:]):
        n = len(ra)
        for i in range(n):
            j = (i + 1) % n
            a0, a1 = (*ra[i], za), (*ra[j], za)
            b0, b1 = (*rb[i], zb), (*rb[j], zb)
            tris.append((a0, a1, b1))
            tris.append((a0, b1, b0))
    for (z, ring), down in ((rings[0], True), (rings[-1], False)):
        cx = sum(p[0] for p in ring) / len(ring)
        cy = sum(p[1] for p in ring) / len(ring)
        for i in range(len(ring)):
            a, b = (*ring[i], z), (*ring[(i + 1) % len(ring)], z)
            tris.append(((cx, cy, z), b, a) if down else ((cx, cy, z), a, b))
    return tris


def cylinder(d, h, n=96):
    ring = [(d / 2 * math.cos(2 * math.pi * i / n), d / 2 * math.sin(2 * math.pi * i / n)) for i in range(n)]
    return loft([(0.0, ring), (h, ring)])


def arch(width_d=60, depth_d=20, height_d=30, radius_d=18, n=48):
    """A bridge over a semicircular tunnel: overhangs grow to horizontal at the crown."""
    prof = [(-width_d / 2, 0), (-radius_d, 0)]
    prof += [(radius_d * math.cos(math.pi - math.pi * k / n), radius_d * math.sin(math.pi - math.pi * k / n))
             for k in range(1, n)]
    prof += [(radius_d, 0), (width_d / 2, 0), (width_d / 2, height_d), (-width_d / 2, height_d)]
    return extrude_xz(prof, depth_d)          # extrude_xz orients it


def window_box(width_d=40, depth_d=20, height_d=25, win_w=24, win_z0=5, win_z1=15):
    """A box with a rectangular window through it: a 24 mm flat bridge over the opening."""
    w, a = width_d / 2, win_w / 2
    # the box minus the window = two touching prisms (the sill, and the pillars with the lintel)
    sill = extrude_xz([(-w, 0), (w, 0), (w, win_z0), (-w, win_z0)], depth_d)
    upper = extrude_xz([(-w, win_z0), (-a, win_z0), (-a, win_z1), (a, win_z1), (a, win_z0), (w, win_z0),
                        (w, height_d), (-w, height_d)], depth_d)
    return sill + upper


def hull(length_d=60, beam_d=24, depth_d=20, n=64, layers=12):
    """A flared boat-hull-like shell: elliptic sections growing with z (overhang ~55 deg at the top)."""
    rings = []
    for k in range(layers + 1):
        z = depth_d * k / layers
        s = 0.35 + 0.65 * math.sin(0.5 * math.pi * k / layers)
        rings.append((z, [(s * length_d / 2 * math.cos(2 * math.pi * i / n),
                           s * beam_d / 2 * math.sin(2 * math.pi * i / n)) for i in range(n)]))
    return loft(rings)


def benchy_like(length_d=40, beam_d=16, hull_h=8, n=96):
    """A small Benchy-like boat: a flared hull with a pointed bow and a round stern (curved
    perimeters on every layer), a cabin with round corners on the deck and a chimney on it.
    The three parts touch at z = hull_h and at the cabin's top (between layer planes)."""
    def hull_ring(s):
        # x = L/2 cos t, y = B/2 sin t sin(t/2): y ~ (L/2 - x) near t = 0, a pointed bow
        return [(s * length_d / 2 * math.cos(t), s * beam_d / 2 * math.sin(t) * math.sin(t / 2))
                for t in (2 * math.pi * i / n for i in range(n))]
    rings = []
    for k in range(9):
        z = hull_h * k / 8
        rings.append((z, hull_ring(0.72 + 0.28 * math.sin(0.5 * math.pi * k / 8))))
    tris = loft(rings)

    def rounded_rect(cx, sx, sy, r, m=12):
        pts = []
        for qx, qy, a0 in ((1, 1, 0.0), (-1, 1, 0.5 * math.pi), (-1, -1, math.pi), (1, -1, 1.5 * math.pi)):
            ox, oy = cx + qx * (sx / 2 - r), qy * (sy / 2 - r)
            pts += [(ox + r * math.cos(a0 + 0.5 * math.pi * j / m), oy + r * math.sin(a0 + 0.5 * math.pi * j / m))
                    for j in range(m + 1)]
        return pts
    cab_top = hull_h + 6
    tris += loft([(hull_h, rounded_rect(-3, 14, 9, 2.5)), (cab_top, rounded_rect(-3.5, 12, 8, 2.0))])
    chim = [(-6 + 2 * math.cos(2 * math.pi * i / 48), 2 * math.sin(2 * math.pi * i / 48)) for i in range(48)]
    tris += loft([(cab_top, chim), (cab_top + 4, chim)])
    return tris


MODELS = {
    "box_30x30x20": lambda: box(30, 30, 20),
    "box_50x20x15": lambda: box(50, 20, 15),
    "box_20x20x30": lambda: box(20, 20, 30),
    "cylinder_d30x20": lambda: cylinder(30, 20),
    "cylinder_d40x10": lambda: cylinder(40, 10),
    "cylinder_d40x25": lambda: cylinder(40, 25),
    "arch": arch,
    "window_box": window_box,
    "hull": hull,
    "benchy_like": benchy_like,
    "cylinder_d40x4": lambda: cylinder(40, 4),
}

if __name__ == "__main__":
    out, names = sys.argv[1], sys.argv[2:] or list(MODELS)     # python3 corpus_models.py DIR [NAME ...]
    for name in names:
        _write(f"{out}/{name}.stl", name, MODELS[name]())
