"""Plans a cohort (a manifest of scans × preparations, as `dentsim batch` reads it) in ParaView,
spread over MPI ranks:

    mpiexec -n N pvbatch examples/paraview/batch_plan.py MANIFEST OUT

Every rank runs its share of the cases (the piece ParaView asks it for: a contiguous run, as
`dentsim batch --shard I/N`), then one rank merges every case into OUT/report.csv and
OUT/report.json: the same report `dentsim batch MANIFEST --out OUT` writes (wall times aside).
"""
import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from dentsim_plugin import plugin_path  # noqa: E402
from paraview import servermanager, simple  # noqa: E402

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("manifest")
parser.add_argument("out")
parser.add_argument("--plugin", default=None, help="DentSim.so (default: $DENTSIM_PLUGIN or this checkout's build)")
args = parser.parse_args()

simple.LoadPlugin(args.plugin or plugin_path(), ns=globals())
ranks = servermanager.vtkProcessModule.GetProcessModule().GetNumberOfLocalPartitions()

start = time.perf_counter()
plan = DentalBatchPlan(ManifestFile=os.path.abspath(args.manifest), OutputDirectory=os.path.abspath(args.out))
plan.UpdatePipeline()
# Gathering the data information waits for every rank: all shards are written.
rows_run = plan.GetDataInformation().GetNumberOfRows()
plan.Step = "Merge report"
plan.UpdatePipeline()
report = servermanager.Fetch(plan)
seconds = time.perf_counter() - start
if report.GetNumberOfRows() == 0 or rows_run != report.GetNumberOfRows():
    sys.__stdout__.write("batch plan failed: %d rows run, %d merged (see the errors above)\n"
                         % (rows_run, report.GetNumberOfRows()))
    sys.exit(1)
cases = len({report.GetValue(r, 0).ToString() for r in range(report.GetNumberOfRows())})
print("%d cases on %d rank(s) in %.2f s; wrote %s" % (cases, ranks, seconds, os.path.join(args.out, "report.csv")))
