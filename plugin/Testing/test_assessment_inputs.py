"""Dental Preparation Assessment inside the pipeline: the original tissues from the DentSim Tissues
Reader, the prepared ones from a Dental Preparation on that reader, graded without a file in
between; the figures agree with the file-based assessment of the same cut, and a missing input
or file is an error that names the property."""
import os
import subprocess

from paraview import servermanager, simple
from vtkmodules.vtkCommonCore import vtkOutputWindow, vtkStringOutputWindow

from dentsim_testing import check, parse_args

args = parse_args()
simple.LoadPlugin(args.plugin, ns=globals())

import pyopenvdb

# Enamel over dentin: two spheres written by pyopenvdb; a groove across the top, 0.3 mm into the dentin.
enamel = pyopenvdb.createLevelSetSphere(radius=3.0, center=(0.0, 0.0, 0.0), voxelSize=0.05)
enamel.name = "enamel"
dentin = pyopenvdb.createLevelSetSphere(radius=2.2, center=(0.0, 0.0, 0.0), voxelSize=0.05)
dentin.name = "dentin"
original = os.path.join(args.temp, "inputs_original.vdb")
pyopenvdb.write(original, grids=[enamel, dentin])
csv = os.path.join(args.temp, "inputs_groove.csv")
with open(csv, "w") as f:
    f.write("t,x,y,z,qw,qx,qy,qz,cut\n0,-1.5,0,4,1,0,0,0,1\n0.5,-1.5,0,1.9,1,0,0,0,1\n"
            "1.5,1.5,0,1.9,1,0,0,0,1\n2,1.5,0,4,1,0,0,0,0\n")


def rows_of(assessment):
    assessment.UpdatePipeline()
    table = servermanager.Fetch(assessment, idx=1)
    return {table.GetValue(r, 0).ToString(): table.GetValue(r, 1).ToDouble() for r in range(table.GetNumberOfRows())}


# From files: dentsim prepare, then the assessment of the two files.
prepared_dir = os.path.join(args.temp, "inputs_prepared")
subprocess.run([args.dentsim, "prepare", original, "--path", csv, "--burr", "round:1.0", "--out", prepared_dir],
               check=True, stdout=subprocess.DEVNULL)
from_files = rows_of(DentalPreparationAssessment(PreparedTissues=prepared_dir, OriginalTissues=original))

# In the pipeline: reader → preparation → assessment, with the reader as the original.
reader = simple.OpenDataFile(original)
prep = DentalPreparation(Tissues=reader, TissueVoxelSizemm=0.05, ToolPathFileCSV=csv, Burr="round:1.0")
piped = DentalPreparationAssessment(Prepared=prep, Original=reader, TissueVoxelSizemm=0.05)
in_pipeline = rows_of(piped)
print("files:", {k: round(v, 4) for k, v in from_files.items()})
print("pipeline:", {k: round(v, 4) for k, v in in_pipeline.items()})
# The pipeline's tissues went through surfaces and back to level sets: the cut's surface may move
# by a fraction of a voxel (0.05 mm), about 0.02 mm3 over this groove's ~1.5 mm2 in each tissue.
for key in ("enamel removed", "dentin removed"):
    a, b = from_files[key], in_pipeline[key]
    check(a > 0.1 and abs(a - b) < max(0.03 * a, 0.03), "%s: files %.4f, pipeline %.4f" % (key, a, b))

# Against itself as the reference, from the pipeline too: no over- or under-cut to speak of.
itself = DentalPreparationAssessment(Prepared=prep, Original=reader, Reference=prep, TissueVoxelSizemm=0.05)
r = rows_of(itself)
check(r["enamel over-cut"] < 0.01 * r["enamel removed"] and r["enamel under-cut"] < 0.01 * r["enamel removed"],
      "itself: %s" % r)
surface = servermanager.Fetch(itself, idx=0)
check(surface.GetPointData().GetScalars().GetName() == "DeviationMm", "coloured by deviation with a reference input")

# Nothing connected and no file: the error names the property; None clears an input.
log = vtkStringOutputWindow()
vtkOutputWindow.SetInstance(log)
piped.Original = None
piped.UpdatePipeline()
text = log.GetOutput()
check("Original Tissues" in text and "no input connected" in text, "names the property: %s" % text)
