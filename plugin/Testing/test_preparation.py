"""Dental Preparation: a groove cut into the capsule phantom along a CSV path and along the same
path as a polyline; the removed-volume table, errors that name the field, and the picture."""
import os

from paraview import servermanager, simple
from vtkmodules.vtkCommonCore import vtkOutputWindow, vtkStringOutputWindow

from dentsim_testing import (check, compare_with_baseline, parse_args, place_camera, show_blocks,
                             tissue_view)

args = parse_args()
simple.LoadPlugin(args.plugin, ns=globals())

# Burr upright (identity quaternion): down into the occlusal enamel of the phantom (top at
# z = 5 mm), along x 1 mm deep, and out; the first and last moves do not cut.
POSES = ([(-1.5, 0.0, 5.6, 0)] + [(-1.5, 0.0, 5.6 - 0.2 * i, 1) for i in range(1, 9)]
         + [(-1.5 + 0.1 * i, 0.0, 4.0, 1) for i in range(1, 31)] + [(1.5, 0.0, 5.6, 0)])
POSES = [(round(x, 4), round(y, 4), round(z, 4), cut) for x, y, z, cut in POSES]  # as in the CSV
csv = os.path.join(args.temp, "groove.csv")
with open(csv, "w") as f:
    f.write("t,x,y,z,qw,qx,qy,qz,cut\n")
    for i, (x, y, z, cut) in enumerate(POSES):
        f.write("%.3f,%.4f,%.4f,%.4f,1,0,0,0,%d\n" % (0.01 * i, x, y, z, cut))


def table_rows(prep):
    table = servermanager.Fetch(prep, idx=1)
    columns = [table.GetColumnName(c) for c in range(table.GetNumberOfColumns())]
    check(columns == ["Tissue", "RemovedVolume", "VolumeBefore", "VolumeAfter"], "columns %s" % columns)
    rows = {}
    for r in range(table.GetNumberOfRows()):
        name = table.GetValue(r, 0).ToString()
        rows[name] = [table.GetValue(r, c).ToDouble() for c in (1, 2, 3)]
    return rows


def check_groove(rows, what):
    check(sorted(rows) == ["dentin", "enamel", "pulp"], "%s: one row per tissue, got %s" % (what, sorted(rows)))
    for name, (removed, before, after) in rows.items():
        check(abs(before - after - removed) < 1e-6 * before, "%s: %s before - after = removed" % (what, name))
    check(rows["enamel"][0] > 1.0, "%s: enamel removed %s" % (what, rows["enamel"]))
    check(rows["pulp"][0] == 0.0, "%s: pulp untouched %s" % (what, rows["pulp"]))


# 1. The path as a CSV file (no input connected).
from_csv = DentalPreparation(PhantomVoxelSizemm=0.08, ToolPathFileCSV=csv, Burr="round:1.0")
from_csv.UpdatePipeline()
csv_rows = table_rows(from_csv)
check_groove(csv_rows, "CSV path")
print("CSV path: removed (mm^3):", {k: round(v[0], 4) for k, v in csv_rows.items()})

# 2. The same path as a polyline with an Orientation point array.
POLYLINE = """
import math
from vtkmodules.vtkCommonCore import vtkDoubleArray, vtkPoints
from vtkmodules.vtkCommonDataModel import vtkCellArray
poses = %r
bad = %r
points = vtkPoints()
points.SetDataTypeToDouble()
orientation = vtkDoubleArray(); orientation.SetName("Orientation"); orientation.SetNumberOfComponents(4)
cut = vtkDoubleArray(); cut.SetName("Cut")
time = vtkDoubleArray(); time.SetName("Time")
for i, (x, y, z, c) in enumerate(poses):
    points.InsertNextPoint(x, y, z)
    orientation.InsertNextTuple4(float("nan") if i == bad else 1.0, 0.0, 0.0, 0.0)
    cut.InsertNextValue(c)
    time.InsertNextValue(0.01 * i)
lines = vtkCellArray()
lines.InsertNextCell(len(poses))
for i in range(len(poses)):
    lines.InsertCellPoint(i)
output.SetPoints(points)
output.SetLines(lines)
for a in (orientation, cut, time):
    output.GetPointData().AddArray(a)
"""
path = simple.ProgrammableSource(OutputDataSetType="vtkPolyData", Script=POLYLINE % (POSES, -1))
prep = DentalPreparation(ToolPath=path, PhantomVoxelSizemm=0.08, Burr="round:1.0")
prep.UpdatePipeline()
poly_rows = table_rows(prep)
check_groove(poly_rows, "polyline path")
for name in csv_rows:
    check(abs(poly_rows[name][0] - csv_rows[name][0]) < 1e-9,
          "polyline and CSV cut the same %s: %s vs %s" % (name, poly_rows[name], csv_rows[name]))
print("polyline path: removed (mm^3):", {k: round(v[0], 4) for k, v in poly_rows.items()})

data = servermanager.Fetch(prep)
names = [data.GetMetaData(i).Get(data.NAME()) for i in range(data.GetNumberOfBlocks())]
check(names == ["enamel", "dentin", "pulp"], "blocks named by tissue, got %s" % names)
removed = data.GetBlock(0).GetFieldData().GetArray("RemovedVolume").GetValue(0)
check(abs(removed - poly_rows["enamel"][0]) < 1e-9, "enamel block carries the removed volume")

# 3. Errors name the field and ParaView recovers.
original_window = vtkOutputWindow.GetInstance()
messages = vtkStringOutputWindow()
vtkOutputWindow.SetInstance(messages)
prep.Burr = "oval:1.0"
prep.UpdatePipeline()
text = messages.GetOutput()
check("DentSim" in text and "oval:1.0" in text, "error names the burr spec: %r" % text)
prep.Burr = "round:1.0"
path.Script = POLYLINE % (POSES, 12)
prep.UpdatePipeline()
text = messages.GetOutput()
check("point 12 array Orientation" in text, "error names the point and array: %r" % text)
vtkOutputWindow.SetInstance(original_window)
print("reported:", [l for l in text.splitlines() if "DentSim" in l])

path.Script = POLYLINE % (POSES, -1)
prep.UpdatePipeline()
check(table_rows(prep) == poly_rows, "recovers after errors")

view = tissue_view()
show_blocks(prep, view, names)
place_camera(view)
compare_with_baseline(view, args, "preparation")
print("PASSED test_preparation")
