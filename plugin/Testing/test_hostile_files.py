"""Hostile files given to every proxy that reads files (Tissues Reader, Dental Preparation, Dental
Haptic Session): a truncated or byte-flipped .vdb, metadata of the wrong type, a bad tool path CSV.
Each gives a VTK error naming the property and the file; ParaView stays up and recovers."""
import os

import pyopenvdb
from paraview import servermanager, simple
from vtkmodules.vtkCommonCore import vtkOutputWindow, vtkStringOutputWindow

from dentsim_testing import check, parse_args

args = parse_args()
simple.LoadPlugin(args.plugin, ns=globals())


def temp(name):
    return os.path.join(args.temp, name)


# A valid file from OpenVDB's own Python tools, and hostile files made from it.
sphere = pyopenvdb.createLevelSetSphere(radius=2.0, center=(0.0, 0.0, 4.0), voxelSize=0.08)
sphere.name = "dentin"
good = temp("hostile_good.vdb")
pyopenvdb.write(good, grids=[sphere])
data = open(good, "rb").read()
with open(temp("hostile_truncated.vdb"), "wb") as f:
    f.write(data[: len(data) // 2])
flipped = bytearray(data)
for pos in range(len(data) // 3, len(data), 997):  # every 997th byte of the voxel data
    flipped[pos] ^= 0x5A
with open(temp("hostile_flipped.vdb"), "wb") as f:
    f.write(bytes(flipped))
typed = pyopenvdb.createLevelSetSphere(radius=2.0, center=(0.0, 0.0, 4.0), voxelSize=0.08)
typed.name = "dentin"
typed["stiffness_n_per_mm"] = "hard"
pyopenvdb.write(temp("hostile_metadata.vdb"), grids=[typed])
negative = pyopenvdb.createLevelSetSphere(radius=2.0, center=(0.0, 0.0, 4.0), voxelSize=0.08)
negative.name = "dentin"
negative["damping_n_s_per_mm"] = -5.0
pyopenvdb.write(temp("hostile_negative.vdb"), grids=[negative])
bad_vdbs = ["hostile_truncated.vdb", "hostile_flipped.vdb", "hostile_metadata.vdb", "hostile_negative.vdb"]

good_csv = temp("hostile_good.csv")
with open(good_csv, "w") as f:
    f.write("t,x,y,z,qw,qx,qy,qz\n0,0,0,7,1,0,0,0\n0.2,0,0,6,1,0,0,0\n")
bad_csv = temp("hostile_bad.csv")
with open(bad_csv, "w") as f:
    f.write("t,x,y,z,qw,qx,qy,qz\n0,0,0,7,1,0,0,0\n0.2,0,nan,6,1,0,0,0\n")

original_window = vtkOutputWindow.GetInstance()


def errors_of(update):
    """The text VTK's error output received while `update` ran."""
    messages = vtkStringOutputWindow()
    vtkOutputWindow.SetInstance(messages)
    try:
        update()
    finally:
        vtkOutputWindow.SetInstance(original_window)
    return messages.GetOutput()


def expect_error(update, label, name):
    text = errors_of(update)
    check(label in text and name in text, "error names %r and %r: %r" % (label, name, text[:400]))
    check(len(text) < 4000, "a short message (%d characters)" % len(text))
    line = next(l for l in text.splitlines() if "DentSim:" in l)
    print("%s / %s: %s" % (label, name, line[line.index("DentSim:"):][:240]))


# Tissues Reader (File Name).
reader = DentSimTissuesReader(FileName=good)
for name in bad_vdbs:
    reader.FileName = temp(name)
    expect_error(reader.UpdatePipeline, "File Name", name)
reader.FileName = good
reader.UpdatePipeline()
check(servermanager.Fetch(reader).GetNumberOfBlocks() == 1, "the reader recovers")
simple.Delete(reader)
simple.SetActiveSource(None)  # else the preparation takes the reader as its tool path input

# Dental Preparation (Tissues File, Tool Path File (CSV)).
prep = DentalPreparation(TissuesFile=good, ToolPathFileCSV=good_csv, Burr="round:1.0")
for name in bad_vdbs:
    prep.TissuesFile = temp(name)
    expect_error(prep.UpdatePipeline, "Tissues File", name)
prep.TissuesFile = good
prep.ToolPathFileCSV = bad_csv
expect_error(prep.UpdatePipeline, "Tool Path File (CSV)", "hostile_bad.csv")
prep.ToolPathFileCSV = good_csv
prep.UpdatePipeline()
check(servermanager.Fetch(prep).GetNumberOfBlocks() == 1, "the preparation recovers")
simple.Delete(prep)

# Dental Haptic Session (Tissues File, Scripted Path (CSV)).
for name in bad_vdbs:
    live = DentalHapticSession(TissuesFile=temp(name), Device="Scripted tool path",
                               ScriptedPathCSV=good_csv, RealTime=0)
    expect_error(live.UpdatePipeline, "Tissues File", name)
    simple.Delete(live)
live = DentalHapticSession(TissuesFile=good, Device="Scripted tool path", ScriptedPathCSV=bad_csv,
                           RealTime=0)
expect_error(live.UpdatePipeline, "Scripted Path (CSV)", "hostile_bad.csv")
simple.Delete(live)
live = DentalHapticSession(TissuesFile=good, Device="Scripted tool path", ScriptedPathCSV=good_csv,
                           RealTime=0)
live.UpdatePipeline()
check(servermanager.Fetch(live).GetNumberOfBlocks() >= 3, "the session recovers")
simple.Delete(live)
print("PASSED test_hostile_files")
