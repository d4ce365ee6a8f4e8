"""Writes this cohort's tool paths: preparations of tooth 36 of `dentsim phantom`'s scan (its
occlusal table around x 24, y 18 mm, cusp tips at z -27.6 mm, LPS), burr upright."""
CX, CY, TOP = 24.0, 18.0, -27.6


def write(name, poses):
    with open(name, "w") as f:
        f.write("t,x,y,z,qw,qx,qy,qz,cut\n")
        for i, (x, y, z, c) in enumerate(poses):
            f.write("%.3f,%.3f,%.3f,%.3f,1,0,0,0,%d\n" % (0.01 * i, x, y, z, c))


def line(a, b, z, n):
    return [(a[0] + (b[0] - a[0]) * i / n, a[1] + (b[1] - a[1]) * i / n, z, 1) for i in range(1, n + 1)]


def plunge(p, z):
    above = TOP + 1.0
    return [(p[0], p[1], above, 0)] + [(p[0], p[1], above + (z - above) * i / 10, 1) for i in range(1, 11)]


def out(p):
    return [(p[0], p[1], TOP + 1.0, 0)]


depth = TOP - 2.0
write("groove_md.csv", plunge((CX - 3, CY), depth) + line((CX - 3, CY), (CX + 3, CY), depth, 60) + out((CX + 3, CY)))
write("groove_bl.csv", plunge((CX, CY - 2.5), depth) + line((CX, CY - 2.5), (CX, CY + 2.5), depth, 50) + out((CX, CY + 2.5)))
box = plunge((CX - 2, CY - 1.5), depth)
for k in range(7):  # a class I box: rows 0.5 mm apart
    y = CY - 1.5 + 0.5 * k
    a, b = ((CX - 2, y), (CX + 2, y)) if k % 2 == 0 else ((CX + 2, y), (CX - 2, y))
    box += line(box[-1][:2], a, depth, 5) + line(a, b, depth, 40)
write("class1_box.csv", box + out(box[-1][:2]))
cross = plunge((CX - 3, CY), depth - 0.3) + line((CX - 3, CY), (CX + 3, CY), depth - 0.3, 60) + out((CX + 3, CY))
cross += plunge((CX, CY - 2.5), depth - 0.3) + line((CX, CY - 2.5), (CX, CY + 2.5), depth - 0.3, 50) + out((CX, CY + 2.5))
write("cross.csv", cross)
