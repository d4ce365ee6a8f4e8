"""For clinicians: open a scan, show the chosen tooth in its tissue colours, and plan a class I
cavity and a crown preparation on it, side by side.

    pvpython examples/paraview/clinician_tooth.py [--scan SCAN] [--tooth 36] [--seed X,Y,Z] [--out DIR]

(or, in the ParaView GUI, View → Python Shell → Run Script, with the same defaults). Without
--scan it makes the built-in molar phantom scan with `dentsim phantom` ($DENTSIM, else `dentsim`
on the PATH, else this checkout's build). Writes OUT/class1.csv and OUT/crown.csv (the tool
paths), OUT/tooth.png (both preparations), OUT/removed.csv (volumes per tissue) and
OUT/tooth.pvsm, a state to open in the GUI (File → Load State).
"""
import argparse
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from dentsim_plugin import HERE, load  # noqa: E402
from paraview import servermanager, simple  # noqa: E402

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--scan", help="CBCT: DICOM folder, .nii, .mha, .nrrd (default: the phantom)")
parser.add_argument("--tooth", type=int, default=36, help="FDI number to label the tooth with")
parser.add_argument("--seed", help="X,Y,Z (mm) inside or near the tooth (default: the phantom's tooth 36)")
parser.add_argument("--voxel", type=float, default=0.1, help="level-set voxel size (mm)")
parser.add_argument("--out", default=None, help="output folder (default: a new temporary one)")
parser.add_argument("--plugin", default=None)
args = parser.parse_args([a for a in sys.argv[1:]] if sys.argv[1:] else [])
out = args.out or tempfile.mkdtemp(prefix="dentsim-tooth-")
os.makedirs(out, exist_ok=True)
load(globals(), args.plugin)

seed = [float(v) for v in args.seed.split(",")] if args.seed else None
scan_path = args.scan
if not scan_path:
    dentsim = os.environ.get("DENTSIM") or shutil.which("dentsim") or os.path.join(HERE, "..", "..", "target", "release", "dentsim")
    scan_path = os.path.join(out, "phantom_scan.mha")
    made = subprocess.run([dentsim, "phantom", "--format", "mha", "--out", scan_path],
                          check=True, capture_output=True, text=True).stdout
    seed = seed or [float(v) for v in re.search(r"near ([-\d.]+),([-\d.]+),([-\d.]+) mm", made).groups()]

scan = simple.OpenDataFile(scan_path)
tooth = DentalTissuesFromScan(Input=scan, ToothFDI=args.tooth, VoxelSizemm=args.voxel,
                              UseSeedPoint=1 if seed else 0, SeedPointmm=seed or [0, 0, 0])
tooth.UpdatePipeline()
enamel = servermanager.Fetch(tooth).GetBlock(0).GetBounds()
cx, cy, top = 0.5 * (enamel[0] + enamel[1]), 0.5 * (enamel[2] + enamel[3]), enamel[5]
half_x, half_y = 0.5 * (enamel[1] - enamel[0]), 0.5 * (enamel[3] - enamel[2])


def write_path(name, poses):
    """t,x,y,z + the burr upright (its axis along +z, the tooth's long axis here) + cut."""
    path = os.path.join(out, name)
    with open(path, "w") as f:
        f.write("t,x,y,z,qw,qx,qy,qz,cut\n")
        for i, (x, y, z, cut) in enumerate(poses):
            f.write("%.3f,%.4f,%.4f,%.4f,1,0,0,0,%d\n" % (0.005 * i, x, y, z, cut))
    return path


def raster(x0, x1, y0, y1, z, step):
    poses, rows = [], int(round((y1 - y0) / step))
    for k in range(rows + 1):
        y = y0 + k * step
        xs = (x0, x1) if k % 2 == 0 else (x1, x0)
        poses += [(xs[0] + (xs[1] - xs[0]) * i / 20.0, y, z, 1) for i in range(21)]
    return poses


def travel(a, b, cut=0):
    """From pose a to b (x, y, z) in steps under 1 mm, so no row is a jump."""
    n = max(1, int(math.dist(a, b) / 0.8) + 1)
    return [(a[0] + (b[0] - a[0]) * i / n, a[1] + (b[1] - a[1]) * i / n, a[2] + (b[2] - a[2]) * i / n, cut)
            for i in range(1, n + 1)]


def block_points(blocks, name):
    """The points of the block called `name` (x, y, z)."""
    for i in range(blocks.GetNumberOfBlocks()):
        if blocks.GetMetaData(i).Get(blocks.NAME()) == name:
            data = blocks.GetBlock(i)
            return [data.GetPoint(k) for k in range(data.GetNumberOfPoints())]
    return []


def outline(points, z0, z1):
    """The convex outline (counter-clockwise x, y) of the points between heights z0 and z1."""
    hull = []
    for p in sorted({(round(x, 3), round(y, 3)) for x, y, z in points if z0 <= z <= z1}):
        hull.append(p)  # Andrew's monotone chain, lower then upper half
    lower, upper = [], []
    for chain, seq in ((lower, hull), (upper, reversed(hull))):
        for p in seq:
            while len(chain) >= 2 and ((chain[-1][0] - chain[-2][0]) * (p[1] - chain[-2][1])
                                       - (chain[-1][1] - chain[-2][1]) * (p[0] - chain[-2][0])) <= 0:
                chain.pop()
            chain.append(p)
    return lower[:-1] + upper[:-1]


def around(hull, inset, z, step=0.2):
    """Poses every `step` mm once around the convex outline, moved `inset` mm inward."""
    n = len(hull)
    poses = []
    for i in range(n):
        (x0, y0), (x1, y1) = hull[i], hull[(i + 1) % n]
        length = math.hypot(x1 - x0, y1 - y0)
        if length == 0:
            continue
        nx, ny = (y1 - y0) / length, -(x1 - x0) / length  # outward for a counter-clockwise outline
        for k in range(max(1, int(length / step))):
            f = k * step / length
            poses.append((x0 + f * (x1 - x0) - inset * nx, y0 + f * (y1 - y0) - inset * ny, z, 1))
    return poses + poses[:1]


def rings(hull, depth, radius, z):
    """Rings around the outline that cut it back to `depth` mm inside with a burr of `radius`:
    the innermost leaves the wall, each next one 1.6 radii further out, until one clears it."""
    out, inset = [], depth - radius
    while inset > -radius:
        out.append(around(hull, inset, z))
        inset -= 1.6 * radius
    return out


def entry(x, y, z):
    above = top + 1.0
    return [(x, y, above, 0)] + [(x, y, above + (z - above) * i / 10.0, 1) for i in range(1, 11)]


# Class I: an occlusal box 2 mm deep, 4 × 3 mm, with a flat-ended cylinder.
depth = top - 2.0
box = raster(cx - 2.0, cx + 2.0, cy - 1.5, cy + 1.5, depth, 0.5)
class1 = write_path("class1.csv", entry(box[0][0], box[0][1], depth) + box + [(box[-1][0], box[-1][1], top + 1.0, 0)])

# Crown: 1.5 mm occlusal reduction, then axial reduction following the tooth's own outline with a
# round-ended taper (ISO taper, 2° half-angle, its axis upright): rings with the tip on the finish
# line 6 mm below the cusp tips cut a 0.8 mm chamfer, rings 1 mm higher take the axial wall 1.2 mm
# in from the height of contour. The rings run around the convex outline of the tooth's surface at
# those heights, from the wall outward until the burr clears the outline.
occlusal = raster(enamel[0] - 0.5, enamel[1] + 0.5, enamel[2] - 0.5, enamel[3] + 0.5, top - 1.5, 0.8)
finish = top - 6.0
tip_radius = 0.4  # the taper's radius near its rounded tip (0.7 mm less 8 mm × tan 2°)
surface_points = [p for name in ("enamel", "dentin") for p in block_points(servermanager.Fetch(tooth), name)]
margin = rings(outline(surface_points, finish - 0.25, finish + 0.25), 0.8, tip_radius, z=finish)
axial = rings(outline(surface_points, finish + 1.0, top - 1.5), 1.2, tip_radius, z=finish + 1.0)
outside = (cx + half_x + 2.0, cy, finish)  # beside the tooth at the finish line: air
poses = entry(occlusal[0][0], occlusal[0][1], top - 1.5) + occlusal
poses += travel(poses[-1][:3], (poses[-1][0], poses[-1][1], top + 1.0))
poses += travel(poses[-1][:3], (outside[0], outside[1], top + 1.0))
poses += travel(poses[-1][:3], outside)
for ring in margin + axial:
    # Enter from the side: begin where the ring passes nearest the point outside.
    first = min(range(len(ring) - 1), key=lambda i: math.dist(ring[i][:2], outside[:2]))
    ring = ring[first:-1] + ring[:first + 1]
    start = (outside[0], outside[1], ring[0][2])
    poses += travel(poses[-1][:3], start) + travel(start, ring[0][:3], cut=1) + ring
    poses += travel(ring[-1][:3], start)
poses += travel(poses[-1][:3], (outside[0], outside[1], top + 1.0))
crown = write_path("crown.csv", poses)

cavity = DentalPreparation(registrationName="Class I cavity", Tissues=tooth, TissueVoxelSizemm=args.voxel,
                           ToolPathFileCSV=class1, Burr="cylinder_flat:1.0:4")
crown_prep = DentalPreparation(registrationName="Crown preparation", Tissues=tooth, TissueVoxelSizemm=args.voxel,
                               ToolPathFileCSV=crown, Burr="taper_round:1.4:8")
with open(os.path.join(out, "removed.csv"), "w") as f:
    f.write("preparation,tissue,removed_mm3\n")
    for name, prep in (("class_I", cavity), ("crown", crown_prep)):
        prep.UpdatePipeline()
        table = servermanager.Fetch(prep, idx=1)
        for r in range(table.GetNumberOfRows()):
            f.write("%s,%s,%.4f\n" % (name, table.GetValue(r, 0).ToString(), table.GetValue(r, 1).ToDouble()))

# Two views side by side, each in the tissue colours (the plugin's default look) with its legend.
layout = simple.CreateLayout("Tooth %d" % args.tooth)
views = []
for prep in (cavity, crown_prep):
    view = simple.CreateView("RenderView")
    simple.AssignViewToLayout(view=view, layout=layout)
    view.OrientationAxesVisibility = 0
    display = simple.Show(prep, view)
    display.SetScalarBarVisibility(view, True)
    view.CameraPosition = [cx + 14.0, cy - 18.0, top + 16.0]
    view.CameraFocalPoint = [cx, cy, top - 4.0]
    view.CameraViewUp = [0.0, 0.0, 1.0]
    simple.ResetCamera(view)
    views.append(view)
layout.SetSize(1200, 500)
simple.SaveScreenshot(os.path.join(out, "tooth.png"), layout, ImageResolution=[1200, 500])
simple.SaveState(os.path.join(out, "tooth.pvsm"))
print("tooth %d: class I and crown preparation planned; wrote %s" % (args.tooth, out))
