"""examples/paraview/clinician_tooth.py as a clinician runs it: the phantom scan, tooth 36 in
tissue colours, a class I cavity and a crown preparation; compared with a baseline picture."""
import csv
import os
import runpy
import sys

from dentsim_testing import check, fail, parse_args

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

from vtkmodules.vtkIOImage import vtkPNGReader  # noqa: E402
from vtkmodules.vtkImagingCore import vtkImageDifference  # noqa: E402
import shutil  # noqa: E402

image, baseline = os.path.join(out, "tooth.png"), os.path.join(args.baselines, "clinician_tooth.png")
if args.update_baseline:
    shutil.copyfile(image, baseline)
elif not os.path.exists(baseline):
    fail("no baseline " + baseline)
else:
    readers = []
    for path in (image, baseline):
        reader = vtkPNGReader()
        reader.SetFileName(path)
        reader.Update()
        readers.append(reader)
    diff = vtkImageDifference()
    diff.SetInputConnection(readers[0].GetOutputPort())
    diff.SetImageConnection(readers[1].GetOutputPort())
    diff.Update()
    print("image difference from baseline: %.2f" % diff.GetThresholdedError())
    check(diff.GetThresholdedError() <= 15, "tooth.png differs from %s; see %s" % (baseline, image))
print("PASSED test_clinician_example")
