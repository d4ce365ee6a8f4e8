"""Opens tissue .vdb files through ParaView's reader factory, as File > Open would."""
import math
import os
import subprocess

from paraview import servermanager, simple

from dentsim_testing import check, parse_args

args = parse_args()
simple.LoadPlugin(args.plugin, ns=globals())


def blocks(path):
    reader = simple.OpenDataFile(path)
    check(reader is not None and reader.GetXMLName() == "DentSimTissueReader",
          "the factory offers the DentSim reader for %s" % path)
    data = servermanager.Fetch(reader)
    return {data.GetMetaData(i).Get(data.NAME()): data.GetBlock(i)
            for i in range(data.GetNumberOfBlocks())}


# A file from OpenVDB's own Python tools, without dentsim metadata: defaults come from the table.
import pyopenvdb

sphere = pyopenvdb.createLevelSetSphere(radius=2.0, center=(1.0, 0.0, 0.0), voxelSize=0.05)
sphere.name = "dentin"
foreign = os.path.join(args.temp, "openvdb_sphere.vdb")
pyopenvdb.write(foreign, grids=[sphere])
found = blocks(foreign)
check(list(found) == ["dentin"], "one block named dentin, got %s" % list(found))
fields = found["dentin"].GetFieldData()
volume = fields.GetArray("VolumeBefore").GetValue(0)
exact = 4.0 / 3.0 * math.pi * 2.0 ** 3
check(abs(volume / exact - 1.0) < 0.01, "sphere volume %.3f vs %.3f" % (volume, exact))
check(abs(fields.GetArray("Stiffness").GetValue(0) - 0.8) < 1e-12, "dentin stiffness from the table")

# A file written by dentsim demo carries its own properties.
out = os.path.join(args.temp, "demo_for_reader")
subprocess.run([args.dentsim, "demo", "--voxel", "0.1", "--out", out], check=True,
               stdout=subprocess.DEVNULL)
found = blocks(os.path.join(out, "tissues.vdb"))
check(sorted(found) == ["dentin", "enamel", "pulp"], "tissues of the demo: %s" % sorted(found))
for name, block in found.items():
    check(block.GetNumberOfCells() > 500, "%s has a surface" % name)
    check(block.GetCellData().GetArray("Tissue") is not None, "%s Tissue array" % name)

# A file that is not a tissue file is refused with a message naming it; ParaView stays up.
from vtkmodules.vtkCommonCore import vtkOutputWindow, vtkStringOutputWindow

not_vdb = os.path.join(args.temp, "not_tissues.vdb")
with open(not_vdb, "w") as f:
    f.write("not an OpenVDB file")
original_window = vtkOutputWindow.GetInstance()
messages = vtkStringOutputWindow()
vtkOutputWindow.SetInstance(messages)
bad = DentSimTissuesReader(FileName=not_vdb)
bad.UpdatePipeline()
vtkOutputWindow.SetInstance(original_window)
check("not_tissues.vdb" in messages.GetOutput(), "error names the file: %r" % messages.GetOutput())
check(len(blocks(os.path.join(out, "tissues.vdb"))) == 3, "still reads after an error")
print("PASSED test_tissue_reader")
