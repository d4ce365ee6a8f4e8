"""Dental Preparation's inputs as a user meets them: created with something selected it binds
nothing by surprise; ToolPath=None (what a Python trace writes) clears; tissues from an upstream
source (a phantom stroke, or a scan through Tissues From Scan) instead of a file; a failed run
leaves no stale output and its error names the property."""
import os

from paraview import servermanager, simple
from vtkmodules.vtkCommonCore import vtkOutputWindow, vtkStringOutputWindow

from test_inputs import phantom_scan
from dentsim_testing import check, parse_args

args = parse_args()
simple.LoadPlugin(args.plugin, ns=globals())


def groove_csv(name, x0, x1, y, z_top, depth):
    """Burr upright: down at x0, along x to x1 `depth` below z_top, and out."""
    path = os.path.join(args.temp, name)
    poses = [(x0, y, z_top + 0.6, 0), (x0, y, z_top - depth, 1)]
    poses += [(x0 + (x1 - x0) * i / 20.0, y, z_top - depth, 1) for i in range(1, 21)]
    poses += [(x1, y, z_top + 0.6, 0)]
    with open(path, "w") as f:
        f.write("t,x,y,z,qw,qx,qy,qz,cut\n")
        for i, (x, y_, z, cut) in enumerate(poses):
            f.write("%.3f,%.4f,%.4f,%.4f,1,0,0,0,%d\n" % (0.01 * i, x, y_, z, cut))
    return path


def removed(prep):
    table = servermanager.Fetch(prep, idx=1)
    return {table.GetValue(r, 0).ToString(): table.GetValue(r, 1).ToDouble() for r in range(table.GetNumberOfRows())}


csv = groove_csv("inputs_groove.csv", -1.5, 1.5, 0.0, 5.0, 1.0)

# 1. Created while a polyline is the active source: neither input is taken from the selection.
POLYLINE = """
from vtkmodules.vtkCommonCore import vtkDoubleArray, vtkPoints
from vtkmodules.vtkCommonDataModel import vtkCellArray
points = vtkPoints()
orientation = vtkDoubleArray(); orientation.SetName("Orientation"); orientation.SetNumberOfComponents(4)
xs = [-1.0 + 0.1 * i for i in range(21)]
for x in xs:
    points.InsertNextPoint(x, 0.0, 4.4)
    orientation.InsertNextTuple4(1.0, 0.0, 0.0, 0.0)
lines = vtkCellArray()
lines.InsertNextCell(len(xs))
for i in range(len(xs)):
    lines.InsertCellPoint(i)
output.SetPoints(points)
output.SetLines(lines)
output.GetPointData().AddArray(orientation)
"""
polyline = simple.ProgrammableSource(OutputDataSetType="vtkPolyData", Script=POLYLINE)
simple.SetActiveSource(polyline)
prep = DentalPreparation(ToolPathFileCSV=csv, PhantomVoxelSizemm=0.1)
check(prep.ToolPath is None or len(prep.ToolPath) == 0, "ToolPath bound by surprise: %s" % prep.ToolPath)
check(prep.Tissues is None or len(prep.Tissues) == 0, "Tissues bound by surprise: %s" % prep.Tissues)
prep.UpdatePipeline()
from_csv = removed(prep)
check(from_csv["enamel"] > 1.0, "CSV groove cut enamel: %s" % from_csv)

# 2. The polyline connected, then cleared as a Python trace writes it: back to the CSV.
prep.ToolPath = polyline
prep.UpdatePipeline()
from_polyline = removed(prep)
check(abs(from_polyline["enamel"] - from_csv["enamel"]) > 0.1, "the polyline is another cut: %s vs %s"
      % (from_polyline, from_csv))
prep.ToolPath = None
prep.UpdatePipeline()
check(removed(prep) == from_csv, "ToolPath=None goes back to the CSV: %s vs %s" % (removed(prep), from_csv))

# 3. Tissues from upstream: the phantom stroke's uncut tissues (a stroke that misses the tooth)
# give the built-in phantom's result to the accuracy of rebuilding level sets from surfaces.
uncut = DentalPhantomStroke(VoxelSizemm=0.1, BurrDiametermm=0.5,
                            StrokeStartmm=[20.0, 20.0, 20.0], StrokeEndmm=[21.0, 20.0, 20.0])
upstream = DentalPreparation(Tissues=uncut, TissueVoxelSizemm=0.1, ToolPathFileCSV=csv)
upstream.UpdatePipeline()
rebuilt = removed(upstream)
print("phantom built in:", from_csv, "from the Tissues input:", rebuilt)
for name in ("enamel", "dentin"):
    check(abs(rebuilt[name] - from_csv[name]) <= 0.05 * (from_csv[name] if from_csv[name] > 0.2 else 0.2),
          "%s removed from rebuilt tissues %.3f vs %.3f" % (name, rebuilt[name], from_csv[name]))

# 4. Scan → tissues → preparation without leaving ParaView.
scan_path = os.path.join(args.temp, "inputs_scan.mha")
seed = phantom_scan(args.dentsim, scan_path)
scan = simple.OpenDataFile(scan_path)
tooth = DentalTissuesFromScan(Input=scan, VoxelSizemm=0.1, UseSeedPoint=1, SeedPointmm=seed)
tooth.UpdatePipeline()
enamel_bounds = servermanager.Fetch(tooth).GetBlock(0).GetBounds()
cx, cy = 0.5 * (enamel_bounds[0] + enamel_bounds[1]), 0.5 * (enamel_bounds[2] + enamel_bounds[3])
tooth_csv = groove_csv("inputs_tooth_groove.csv", cx - 1.5, cx + 1.5, cy, enamel_bounds[5], 2.0)
on_tooth = DentalPreparation(Tissues=tooth, TissueVoxelSizemm=0.1, ToolPathFileCSV=tooth_csv)
on_tooth.UpdatePipeline()
tooth_removed = removed(on_tooth)
print("scan -> tissues -> preparation removed:", tooth_removed)
check(tooth_removed["enamel"] > 0.5, "the groove cut the scanned tooth's enamel: %s" % tooth_removed)

# 5. A failed run: its error names the property, and no stale output stays behind.
original_window = vtkOutputWindow.GetInstance()
messages = vtkStringOutputWindow()
vtkOutputWindow.SetInstance(messages)
prep.ToolPathFileCSV = os.path.join(args.temp, "no_such_path.csv")
prep.UpdatePipeline()
text = messages.GetOutput()
vtkOutputWindow.SetInstance(original_window)
check("Tool Path File (CSV)" in text and "no_such_path.csv" in text, "error names the property: %r" % text)
check(servermanager.Fetch(prep).GetNumberOfBlocks() == 0, "no stale tissues after a failed run")
check(servermanager.Fetch(prep, idx=1).GetNumberOfRows() == 0, "no stale table after a failed run")
prep.ToolPathFileCSV = csv
prep.UpdatePipeline()
check(removed(prep) == from_csv, "recovers after the error")
# 6. A Python trace of the GUI-like workflow (it writes ToolPath=None) replays to the same cut.
from paraview import smtrace  # noqa: E402

smtrace.start_trace()
traced_stroke = DentalPhantomStroke(VoxelSizemm=0.1, BurrDiametermm=0.5,
                                    StrokeStartmm=[20.0, 20.0, 20.0], StrokeEndmm=[21.0, 20.0, 20.0])
simple.SetActiveSource(traced_stroke)
traced = DentalPreparation(Tissues=traced_stroke, TissueVoxelSizemm=0.1, ToolPathFileCSV=csv)
traced.UpdatePipeline()
trace = smtrace.stop_trace()
check("ToolPath=None" in trace and "Tissues=" in trace, "the trace names both inputs: %s" % trace)
replay = {}
exec(compile(trace, "trace", "exec"), dict(globals()), replay)
replayed = [v for v in replay.values() if hasattr(v, "GetXMLName") and v.GetXMLName() == "DentSimPreparation"]
check(len(replayed) == 1, "the trace makes one preparation")
replayed[0].UpdatePipeline()
check(removed(replayed[0]) == removed(traced), "the trace replays the cut: %s vs %s" % (removed(replayed[0]), removed(traced)))
print("PASSED test_preparation_inputs")
