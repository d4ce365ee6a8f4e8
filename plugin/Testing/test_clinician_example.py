"""examples/paraview/clinician_tooth.py as a clinician runs it: the phantom scan, tooth 36 in
tissue colours, a class I cavity and a crown preparation that follows the tooth's outline;
compared with a baseline picture."""
import csv
import math
import os
import runpy
import sys

from dentsim_testing import check, compare_image, parse_args

args = parse_args()
example = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "examples", "paraview", "clinician_tooth.py")
out = os.path.join(args.temp, "clinician")
os.environ["DENTSIM"] = args.dentsim
sys.argv = [example, "--out", out, "--plugin", args.plugin]
example_globals = runpy.run_path(example, run_name="__main__")

with open(os.path.join(out, "removed.csv")) as f:
    removed = {(r["preparation"], r["tissue"]): float(r["removed_mm3"]) for r in csv.DictReader(f)}
print("removed (mm^3):", removed)
check(removed[("class_I", "enamel")] > 5.0, "the class I box cut enamel")
check(removed[("crown", "enamel")] > 5.0 * removed[("class_I", "enamel")], "the crown reduction takes far more")
check(removed[("class_I", "pulp")] == 0.0 and removed[("crown", "pulp")] == 0.0, "the pulp is untouched")
check(os.path.getsize(os.path.join(out, "tooth.pvsm")) > 1000, "a state file for the GUI")

# The crown's axial reduction follows the tooth: between the chamfer and the occlusal reduction,
# every point left of enamel and dentin lies at least the 1.2 mm reduction (less a 0.1 mm voxel)
# inside the original tooth's convex outline at those heights: no fin of enamel is left standing.
from paraview import servermanager  # noqa: E402

g = example_globals
band = (g["finish"] + 1.5, g["top"] - 2.0)


def surface(source):
    return [p for name in ("enamel", "dentin") for p in g["block_points"](servermanager.Fetch(source), name)]


def depth_inside(hull, x, y):
    """How far (x, y) lies inside the counter-clockwise convex outline."""
    edges = zip(hull, hull[1:] + hull[:1])
    return min(((x1 - x0) * (y - y0) - (y1 - y0) * (x - x0)) / math.hypot(x1 - x0, y1 - y0) for (x0, y0), (x1, y1) in edges
               if (x1, y1) != (x0, y0))


hull = g["outline"](surface(g["tooth"]), *band)
left = [depth_inside(hull, x, y) for x, y, z in surface(g["crown_prep"]) if band[0] <= z <= band[1]]
print("crown: %d surface points between %.2f and %.2f mm, the least reduced %.3f mm inside the outline"
      % (len(left), band[0], band[1], min(left)))
check(len(left) > 1000 and min(left) >= 1.1, "the axial reduction follows the outline, 1.2 mm deep: %.3f" % min(left))

compare_image(os.path.join(out, "tooth.png"), args, "clinician_tooth")
print("PASSED test_clinician_example")
