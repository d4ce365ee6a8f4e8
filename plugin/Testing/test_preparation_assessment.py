"""Dental Preparation Assessment: a groove cut by dentsim prepare into a sphere written by
pyopenvdb, graded against its original and a shallower reference groove; the table, the surface's
arrays, a picture coloured by deviation, and an error that names the property."""
import json
import os
import subprocess

from paraview import servermanager, simple
from vtkmodules.vtkCommonCore import vtkOutputWindow, vtkStringOutputWindow

from dentsim_testing import check, parse_args, tissue_view

args = parse_args()
simple.LoadPlugin(args.plugin, ns=globals())

import pyopenvdb

sphere = pyopenvdb.createLevelSetSphere(radius=3.0, center=(0.0, 0.0, 0.0), voxelSize=0.05)
sphere.name = "enamel"
original = os.path.join(args.temp, "assess_original.vdb")
pyopenvdb.write(original, grids=[sphere])


def groove(depth, name):
    """A 1.0 mm round burr along x across the top of the sphere, its tip `depth` below it."""
    csv = os.path.join(args.temp, name + ".csv")
    z = 3.0 - depth
    with open(csv, "w") as f:
        f.write("t,x,y,z,qw,qx,qy,qz,cut\n0,-1.5,0,4,1,0,0,0,1\n0.5,-1.5,0,%.3f,1,0,0,0,1\n"
                "1.5,1.5,0,%.3f,1,0,0,0,1\n2,1.5,0,4,1,0,0,0,0\n" % (z, z))
    out = os.path.join(args.temp, name)
    subprocess.run([args.dentsim, "prepare", original, "--path", csv, "--burr", "round:1.0",
                    "--out", out], check=True, stdout=subprocess.DEVNULL)
    return out


prepared, reference = groove(0.8, "assess_prepared"), groove(0.5, "assess_reference")
assessment = DentalPreparationAssessment(PreparedTissues=prepared, OriginalTissues=original,
                                         ReferencePreparation=reference)
assessment.UpdatePipeline()
table = servermanager.Fetch(assessment, idx=1)
columns = [table.GetColumnName(c) for c in range(table.GetNumberOfColumns())]
check(columns == ["Criterion", "Value", "Unit", "Range", "Verdict", "Source"], "columns %s" % columns)
rows = {table.GetValue(r, 0).ToString(): table.GetValue(r, 1).ToDouble() for r in range(table.GetNumberOfRows())}
removed = json.load(open(os.path.join(prepared, "prepare.json")))["removed_mm3"]["enamel"]
check(abs(rows["enamel removed"] - removed) < 1e-6 * removed, "removed %s vs prepare's %s" % (rows["enamel removed"], removed))
# The deeper groove contains the shallower: under-cut is only the surfaces' discretisation.
check(rows["enamel over-cut"] > 0.3 and rows["enamel under-cut"] < 0.02 * rows["enamel over-cut"], "over/under-cut %s" % rows)
check(abs(rows["deviation max"] - 0.3) < 0.05, "deepest over-cut %s (0.3 mm)" % rows["deviation max"])
surface = servermanager.Fetch(assessment, idx=0)
check(surface.GetNumberOfCells() > 1000, "surface cells %d" % surface.GetNumberOfCells())
for name in ("DeviationMm", "CutDepthMm"):
    array = surface.GetPointData().GetArray(name)
    check(array is not None and array.GetNumberOfTuples() == surface.GetNumberOfPoints(), name)
check(surface.GetFieldData().GetAbstractArray("AssessmentJSON") is not None, "the JSON rides along")
print("assessment:", {k: round(v, 4) for k, v in rows.items()})

# The picture: the surface coloured by deviation on a diverging map centred on 0.
view = tissue_view()
display = simple.Show(assessment, view)
simple.ColorBy(display, ("POINTS", "DeviationMm"))
lut = simple.GetColorTransferFunction("DeviationMm")
lut.ApplyPreset("Cool to Warm", True)
lut.RescaleTransferFunction(-0.3, 0.3)
view.CameraPosition = [0.0, -6.0, 12.0]
view.CameraFocalPoint = [0.0, 0.0, 2.0]
view.CameraViewUp = [0.0, 0.0, 1.0]
simple.Render(view)
picture = os.path.join(args.temp, "preparation_assessment.png")
simple.SaveScreenshot(picture, view, ImageResolution=[800, 600])
check(os.path.getsize(picture) > 10000, "picture written")

# A missing original: a VTK error naming the property and the file; ParaView stays up.
original_window = vtkOutputWindow.GetInstance()
messages = vtkStringOutputWindow()
vtkOutputWindow.SetInstance(messages)
bad = DentalPreparationAssessment(PreparedTissues=prepared, OriginalTissues=os.path.join(args.temp, "missing.vdb"))
bad.UpdatePipeline()
vtkOutputWindow.SetInstance(original_window)
text = messages.GetOutput()
check("Original Tissues" in text and "missing.vdb" in text, "error names the property and file: %r" % text)
print("ok")
