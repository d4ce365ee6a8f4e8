"""examples/paraview/clinician_tooth.py as a clinician runs it: the phantom scan, tooth 36 in
tissue colours, a class I cavity and a crown preparation; compared with a baseline picture."""
import csv
import os
import runpy
import sys

from dentsim_testing import check, compare_image, parse_args

args = parse_args()
example = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "examples", "paraview", "clinician_tooth.py")
out = os.path.join(args.temp, "clinician")
os.environ["DENTSIM"] = args.dentsim
sys.argv = [example, "--out", out, "--plugin", args.plugin]
runpy.run_path(example, run_name="__main__")

with open(os.path.join(out, "removed.csv")) as f:
    removed = {(r["preparation"], r["tissue"]): float(r["removed_mm3"]) for r in csv.DictReader(f)}
print("removed (mm^3):", removed)
check(removed[("class_I", "enamel")] > 5.0, "the class I box cut enamel")
check(removed[("crown", "enamel")] > 5.0 * removed[("class_I", "enamel")], "the crown reduction takes far more")
check(removed[("class_I", "pulp")] == 0.0 and removed[("crown", "pulp")] == 0.0, "the pulp is untouched")
check(os.path.getsize(os.path.join(out, "tooth.pvsm")) > 1000, "a state file for the GUI")

compare_image(os.path.join(out, "tooth.png"), args, "clinician_tooth")
print("PASSED test_clinician_example")
