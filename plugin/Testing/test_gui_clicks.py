"""GUI test under Xvfb, driven by clicks: ParaView plays gui_clicks.xml (menus, the properties
panel, the Tissues input selector, Apply, closing a view, File > Save State), compares
its view with a baseline picture, then pvbatch checks the saved state: the pipeline is wired as
clicked and the clicked preparation removes what the same pipeline made in Python removes."""
import os
import shutil
import subprocess
import sys

from test_inputs import gui_driver_args, occlusal_groove, phantom_scan

args = gui_driver_args("--pvbatch")

here = os.path.dirname(os.path.abspath(__file__))
temp = os.path.join(args.temp, "gui_clicks")
shutil.rmtree(temp, ignore_errors=True)
os.makedirs(temp)
seed = phantom_scan(args.dentsim, os.path.join(temp, "clicks_scan.mha"))
occlusal_groove(os.path.join(temp, "clicks_groove.csv"))
events = open(os.path.join(here, "gui_clicks.xml")).read().replace("@TEMP@", temp)
for axis, value in zip("XYZ", seed):
    events = events.replace("@SEED_%s@" % axis, "%g" % value)
script = os.path.join(temp, "gui_clicks.xml")
with open(script, "w") as f:
    f.write(events)

baseline = os.path.join(args.baselines, "gui_clicks.png")
compare_with = os.path.join(temp, "new_baseline.png") if args.update_baseline else baseline
env = dict(os.environ, HOME=temp)  # a fresh user: no settings of ours
env.pop("PV_PLUGIN_PATH", None)
run = subprocess.run([args.paraview, "--dr", "--plugin-search-paths=" + os.path.dirname(args.plugin), "--plugins=DentSim",
                      "--test-script=" + script, "--test-baseline=" + compare_with, "--test-threshold=15",
                      "--test-directory=" + temp, "--exit"],
                     env=env, capture_output=True, text=True, timeout=600)
log = run.stdout + run.stderr
if args.update_baseline:
    shutil.copyfile(compare_with, baseline)
    print("baseline written:", baseline)
    sys.exit(0)
played = "Success =  true" in log
print("paraview exit %d; events played: %s" % (run.returncode, played))
if run.returncode != 0 or not played:
    print(log[-6000:])
    print("FAILED: the clicks did not play, or the view differs from %s (test image in %s)" % (baseline, temp))
    sys.exit(1)
warnings = [l for l in log.splitlines() if "DentSim" in l and ("WARN" in l or "ERR" in l)]
if warnings:
    print("FAILED: the GUI logged about DentSim:\n" + "\n".join(warnings))
    sys.exit(1)

check = subprocess.run([args.pvbatch, os.path.join(here, "test_gui_clicks_state.py"), "--plugin", args.plugin,
                        "--baselines", args.baselines, "--temp", temp, "--dentsim", args.dentsim],
                       capture_output=True, text=True, timeout=600)
print(check.stdout[-4000:] + check.stderr[-2000:])
sys.exit(check.returncode)
