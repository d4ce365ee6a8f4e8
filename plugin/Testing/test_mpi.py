"""Run by test_mpi_driver.py under 1 and under 2 MPI ranks: what each source makes, gathered
from every rank, written to a JSON summary the driver compares. Each source answers piece
requests (the rank asked for piece 0 does the work, the others answer empty), so the gathered
data must equal one rank's: same blocks, same point counts, nothing twice."""
import argparse
import json
import os
import sys

from paraview import servermanager, simple

from test_inputs import phantom_scan

parser = argparse.ArgumentParser()
parser.add_argument("--plugin", required=True)
parser.add_argument("--temp", required=True)
parser.add_argument("--dentsim", required=True)
parser.add_argument("--cohort", required=True, help="the example cohort's folder")
parser.add_argument("--summary", required=True)
args = parser.parse_args()
simple.LoadPlugin(args.plugin, ns=globals())
ranks = servermanager.vtkProcessModule.GetProcessModule().GetNumberOfLocalPartitions()


def leaves(data, name="", out=None):
    """(name, points, cells) of every non-empty polydata leaf of a gathered object."""
    out = [] if out is None else out
    if data is None:
        return out
    if data.IsA("vtkMultiBlockDataSet"):
        for i in range(data.GetNumberOfBlocks()):
            meta = data.GetMetaData(i) if data.HasMetaData(i) else None
            child = meta.Get(data.NAME()) if meta is not None and meta.Has(data.NAME()) else name
            leaves(data.GetBlock(i), child, out)
    elif data.IsA("vtkPolyData") and data.GetNumberOfPoints() > 0:
        out.append([name, data.GetNumberOfPoints(), data.GetNumberOfCells()])
    return out


def summary(proxy):
    proxy.UpdatePipeline()
    info = proxy.GetDataInformation()
    return {"points": info.GetNumberOfPoints(), "leaves": leaves(servermanager.Fetch(proxy))}


result = {"ranks": ranks}
result["phantom_stroke"] = summary(DentalPhantomStroke(VoxelSizemm=0.1))

csv = os.path.join(args.cohort, "groove_md.csv")
scan_path = os.path.join(args.temp, "mpi_scan.mha")
seed = phantom_scan(args.dentsim, scan_path)
scan = simple.OpenDataFile(scan_path)
tooth = DentalTissuesFromScan(Input=scan, VoxelSizemm=0.1, UseSeedPoint=1, SeedPointmm=seed)
result["tissues_from_scan"] = summary(tooth)

prep = DentalPreparation(Tissues=tooth, TissueVoxelSizemm=0.1, ToolPathFileCSV=csv, Burr="round:1.0")
result["preparation"] = summary(prep)
table = servermanager.Fetch(prep, idx=1)
result["preparation_table"] = sorted(
    [table.GetValue(r, 0).ToString(), round(table.GetValue(r, 1).ToDouble(), 9)] for r in range(table.GetNumberOfRows()))

# The cohort: rows run (summed over ranks: no case twice) and the merged report.
# The example cohort's manifest, on the scan made above (the example's own is made by the user).
with open(os.path.join(args.cohort, "manifest.json")) as f:
    cohort = json.load(f)
for s in cohort["scans"]:
    s["scan"] = scan_path
for p in cohort["preparations"]:
    p["path"] = os.path.join(args.cohort, p["path"])
manifest = os.path.join(args.temp, "mpi_manifest.json")
with open(manifest, "w") as f:
    json.dump(cohort, f)
out = os.path.join(args.temp, "mpi_batch_%d" % ranks)
plan = DentalBatchPlan(ManifestFile=manifest, OutputDirectory=out)
plan.UpdatePipeline()
result["batch_rows_run"] = plan.GetDataInformation().GetNumberOfRows()
plan.Step = "Merge report"
plan.UpdatePipeline()
with open(os.path.join(out, "report.csv")) as f:
    result["batch_report"] = [line.rsplit(",", 1)[0] for line in f.read().splitlines()]  # less seconds
reader = simple.OpenDataFile(os.path.join(out, "cases", "molar36_0.05mm__cross", "tissues.vdb"))
result["reader"] = summary(reader)

with open(args.summary, "w") as f:
    json.dump(result, f, indent=1)
sys.__stdout__.write("wrote %s (%d ranks)\n" % (args.summary, ranks))
