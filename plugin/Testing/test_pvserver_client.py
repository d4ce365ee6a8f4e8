"""Client half of the pvserver test (run by test_pvserver.py): connects to a pvserver on
loopback, loads DentSim with examples/paraview/dentsim_plugin.load (whether or not the server
auto-loaded it), plans a preparation on the server and fetches the removed-volume table."""
import argparse
import os
import sys

from paraview import servermanager, simple

parser = argparse.ArgumentParser()
parser.add_argument("--port", type=int, required=True)
parser.add_argument("--plugin", required=True)
parser.add_argument("--examples", required=True)
parser.add_argument("--csv", required=True)
args = parser.parse_args()

sys.path.insert(0, args.examples)
import dentsim_plugin  # noqa: E402

simple.Connect("localhost", args.port)
if not servermanager.ActiveConnection.IsRemote():
    sys.__stdout__.write("FAILED: not connected to the pvserver\n")
    os._exit(1)
dentsim_plugin.load(globals(), args.plugin)
prep = DentalPreparation(PhantomVoxelSizemm=0.1, ToolPathFileCSV=args.csv, Burr="round:1.0")
prep.UpdatePipeline()
table = servermanager.Fetch(prep, idx=1)
rows = {table.GetValue(r, 0).ToString(): table.GetValue(r, 1).ToDouble() for r in range(table.GetNumberOfRows())}
tissues = servermanager.Fetch(prep)
names = [tissues.GetMetaData(i).Get(tissues.NAME()) for i in range(tissues.GetNumberOfBlocks())]
if table.GetClassName() != "vtkTable" or sorted(rows) != ["dentin", "enamel", "pulp"] or rows["enamel"] <= 0.5:
    sys.__stdout__.write("FAILED: table %s %s\n" % (table.GetClassName(), rows))
    os._exit(1)
if names != ["enamel", "dentin", "pulp"]:
    sys.__stdout__.write("FAILED: blocks %s\n" % names)
    os._exit(1)
sys.__stdout__.write("client: removed %s\n" % rows)
sys.__stdout__.write("PASSED client\n")
