"""GUI test under Xvfb: the ParaView GUI started with the plugin (as a user with it auto-loaded),
test_gui_workflow_script.py run in it as a startup script (which ends the GUI), the picture
compared with a baseline."""
import os
import shutil
import subprocess
import sys

from test_inputs import gui_driver_args, occlusal_groove, phantom_scan

args = gui_driver_args()

temp = os.path.join(args.temp, "gui")
shutil.rmtree(temp, ignore_errors=True)
os.makedirs(temp)
phantom_scan(args.dentsim, os.path.join(temp, "gui_scan.mha"))
occlusal_groove(os.path.join(temp, "gui_groove.csv"))
env = dict(os.environ, DENTSIM_GUI_TEMP=temp, HOME=temp)  # a fresh user: no settings of ours
env.pop("PV_PLUGIN_PATH", None)
script = os.path.join(os.path.dirname(os.path.abspath(__file__)), "test_gui_workflow_script.py")
run = subprocess.run([args.paraview, "--dr", "--plugin-search-paths=" + os.path.dirname(args.plugin),
                      "--plugins=DentSim", "--script=" + script],
                     env=env, capture_output=True, text=True, timeout=600)
log = run.stdout + run.stderr
result_file = os.path.join(temp, "gui_workflow.result")
result = open(result_file).read().strip() if os.path.exists(result_file) else "no result (the script did not run)"
print("paraview exit %d; %s" % (run.returncode, result))
if not result.startswith("PASSED"):
    print(log[-4000:])
    sys.exit(1)
warnings = [l for l in log.splitlines() if "DentSim" in l and ("WARN" in l or "ERR" in l)]
if warnings or "input_selector" in log:
    print("FAILED: the GUI logged about DentSim:\n" + "\n".join(warnings))
    sys.exit(1)

image, baseline = os.path.join(temp, "gui_workflow.png"), os.path.join(args.baselines, "gui_workflow.png")
if args.update_baseline:
    shutil.copyfile(image, baseline)
    sys.exit(0)
check = """
import sys
from vtkmodules.vtkIOImage import vtkPNGReader
from vtkmodules.vtkImagingCore import vtkImageDifference
r = []
for p in sys.argv[1:3]:
    x = vtkPNGReader(); x.SetFileName(p); x.Update(); r.append(x)
d = vtkImageDifference(); d.SetInputConnection(r[0].GetOutputPort()); d.SetImageConnection(r[1].GetOutputPort()); d.Update()
print(d.GetThresholdedError())
"""
if not os.path.exists(baseline):
    print("FAILED: no baseline %s (check %s, then --update-baseline)" % (baseline, image))
    sys.exit(1)
error = float(subprocess.run([sys.executable, "-c", check, image, baseline], capture_output=True, text=True,
                             check=True).stdout.split()[-1])
print("image difference from baseline gui_workflow: %.2f (threshold 15)" % error)
sys.exit(0 if error <= 15 else 1)
