"""The MPI test: test_mpi.py under one pvbatch and under `mpiexec -n 2 pvbatch`; every source's
gathered output and the cohort's report must be the same (and the cohort's cases run once)."""
import argparse
import json
import os
import subprocess
import sys

parser = argparse.ArgumentParser()
parser.add_argument("--pvbatch", required=True)
parser.add_argument("--mpiexec", required=True)
parser.add_argument("--plugin", required=True)
parser.add_argument("--temp", required=True)
parser.add_argument("--dentsim", required=True)
parser.add_argument("--cohort", required=True)
args = parser.parse_args()

env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
script = os.path.join(os.path.dirname(os.path.abspath(__file__)), "test_mpi.py")
common = ["--plugin", args.plugin, "--temp", args.temp, "--dentsim", args.dentsim, "--cohort", args.cohort]
summaries = {}
for ranks in (1, 2):
    path = os.path.join(args.temp, "mpi_summary_%d.json" % ranks)
    if os.path.exists(path):
        os.remove(path)
    launcher = [args.mpiexec, "--oversubscribe", "--mca", "mpi_yield_when_idle", "1", "-n", str(ranks)]
    run = subprocess.run(launcher + [args.pvbatch, script] + common + ["--summary", path], env=env,
                         capture_output=True, text=True, timeout=600)
    if run.returncode != 0 or not os.path.exists(path):
        print(run.stdout, run.stderr)
        print("FAILED: test_mpi.py under %d rank(s) (exit %d)" % (ranks, run.returncode))
        sys.exit(1)
    with open(path) as f:
        summaries[ranks] = json.load(f)

one, two = summaries[1], summaries[2]
failed = False
if two.get("ranks") != 2:
    print("FAILED: the second run had %s ranks, not 2" % two.get("ranks"))
    failed = True
for key in sorted(k for k in one if k != "ranks"):
    if one[key] != two.get(key):
        print("FAILED: %s differs under 2 ranks:\n  1 rank:  %s\n  2 ranks: %s" % (key, one[key], two.get(key)))
        failed = True
    else:
        print("same under 1 and 2 ranks: %s" % key)
names = sorted(name for name, _, _ in one["preparation"]["leaves"])
if names != ["dentin", "enamel", "pulp"] or one["batch_rows_run"] != 24:
    print("FAILED: expected three tissues and 8 cases × 3 tissues run: %s, %s" % (names, one["batch_rows_run"]))
    failed = True
sys.exit(1 if failed else 0)
