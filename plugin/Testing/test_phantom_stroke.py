"""Loads the DentSim plugin as a user would, builds the phantom stroke, checks it, renders it."""
from paraview import servermanager, simple

from dentsim_testing import (check, compare_with_baseline, parse_args, place_camera, show_blocks,
                             tissue_view)

args = parse_args()
# LoadPlugin puts the proxies named by their XML labels into this namespace.
simple.LoadPlugin(args.plugin, ns=globals())

source = DentalPhantomStroke()
check(abs(source.VoxelSizemm - 0.05) < 1e-12, "default voxel size")
source.VoxelSizemm = 0.08
source.StrokeStartmm = [-2.0, 0.0, 4.2]
source.StrokeEndmm = [1.0, 0.0, 2.9]
source.UpdatePipeline()

data = servermanager.Fetch(source)
names = [data.GetMetaData(i).Get(data.NAME()) for i in range(data.GetNumberOfBlocks())]
check(names == ["enamel", "dentin", "pulp"], "blocks named by tissue, got %s" % names)
removed = {}
for i, name in enumerate(names):
    block = data.GetBlock(i)
    check(block.GetNumberOfCells() > 1000, "%s has a surface" % name)
    tissue = block.GetCellData().GetArray("Tissue")
    check(tissue is not None and tissue.GetRange()[0] == tissue.GetRange()[1], "%s Tissue array" % name)
    fields = block.GetFieldData()
    check(fields.GetAbstractArray("TissueName").GetValue(0) == name, "%s TissueName" % name)
    check(fields.GetArray("Stiffness").GetValue(0) > 0.0, "%s Stiffness" % name)
    before = fields.GetArray("VolumeBefore").GetValue(0)
    after = fields.GetArray("VolumeAfter").GetValue(0)
    removed[name] = fields.GetArray("RemovedVolume").GetValue(0)
    check(abs(before - after - removed[name]) < 1e-6 * before, "%s volume bookkeeping" % name)
    normals = block.GetPointData().GetNormals()
    check(normals is not None and normals.GetNumberOfTuples() == block.GetNumberOfPoints(), "normals")
check(removed["enamel"] > 1.0 and removed["dentin"] > 0.0 and removed["pulp"] == 0.0,
      "stroke removes enamel and dentin only: %s" % removed)
print("removed volume per tissue (mm^3):", removed)

view = tissue_view()
show_blocks(source, view, names)
place_camera(view)
compare_with_baseline(view, args, "phantom_stroke")
print("PASSED test_phantom_stroke")
