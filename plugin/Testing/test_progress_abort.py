"""Progress and abort: Tissues From Scan, Dental Preparation and Dental Preparation Assessment
report progress between 0 and 1 while they work (ParaView's progress bar), and an abort part-way
(during the cut, during segmentation, during grading) stops the work there with an error saying
so and empty outputs; the next run works again."""
import os

from paraview import servermanager, simple
from vtkmodules.vtkCommonCore import vtkCommand, vtkOutputWindow, vtkStringOutputWindow

from test_inputs import phantom_scan
from dentsim_testing import check, parse_args

args = parse_args()
simple.LoadPlugin(args.plugin, ns=globals())

scan_path = os.path.join(args.temp, "progress_scan.mha")
seed = phantom_scan(args.dentsim, scan_path)
csv = os.path.join(args.temp, "progress_box.csv")
# A class I box raster 2 mm into tooth 36's occlusal table, rows 0.125 mm apart, 0.05 mm steps:
# the cut must outlast several of the filter's 25 ms progress polls even on a quiet machine
# (with rows 0.5 mm apart it once ended within three; with rows 0.25 mm apart and 0.1 mm steps,
# 541 segments, within two or three on a quiet 2-core machine).
with open(csv, "w") as f:
    f.write("t,x,y,z,qw,qx,qy,qz,cut\n0,22,16.5,-26.6,1,0,0,0,0\n")
    rows = [(22 + 0.05 * i if k % 2 == 0 else 26 - 0.05 * i, 16.5 + 0.125 * k) for k in range(25) for i in range(81)]
    f.writelines("%.3f,%.3f,%.3f,-29.6,1,0,0,0,1\n" % (0.005 * (j + 1), x, y) for j, (x, y) in enumerate(rows))


def watch(proxy, abort_at=None):
    """Progress values the algorithm reports during its next update; aborts past `abort_at`."""
    algorithm = proxy.GetClientSideObject()
    seen = []

    def on_progress(obj, event):
        seen.append(obj.GetProgress())
        if abort_at is not None and obj.GetProgress() > abort_at:
            obj.SetAbortExecute(1)
    tag = algorithm.AddObserver(vtkCommand.ProgressEvent, on_progress)
    return seen, lambda: algorithm.RemoveObserver(tag)


scan = simple.OpenDataFile(scan_path)
tooth = DentalTissuesFromScan(Input=scan, VoxelSizemm=0.12, UseSeedPoint=1, SeedPointmm=seed)
seen, stop = watch(tooth)
tooth.UpdatePipeline()
stop()
middle = [p for p in seen if 0.0 < p < 1.0]
print("Tissues From Scan progress:", [round(p, 2) for p in seen[:12]], "...", len(seen), "events")
check(len(set(middle)) >= 3, "segmentation reports progress along the way: %s" % seen)
check(seen == sorted(seen) and seen[-1] == 1.0, "progress only grows, to 1: %s" % seen)

prep = DentalPreparation(Tissues=tooth, TissueVoxelSizemm=0.12, ToolPathFileCSV=csv, Burr="cylinder_flat:1.0:4")
seen, stop = watch(prep)
prep.UpdatePipeline()
stop()
middle = [p for p in seen if 0.0 < p < 1.0]
print("Dental Preparation progress:", len(seen), "events,", len(set(middle)), "between 0 and 1")
check(len(set(middle)) >= 3, "the cut reports progress along the way: %s" % seen)
table = servermanager.Fetch(prep, idx=1)
full = {table.GetValue(r, 0).ToString(): table.GetValue(r, 1).ToDouble() for r in range(table.GetNumberOfRows())}
check(full["enamel"] > 1.0, "the box cut enamel: %s" % full)

original_window = vtkOutputWindow.GetInstance()
messages = vtkStringOutputWindow()
vtkOutputWindow.SetInstance(messages)
prep.Burr = "cylinder_flat:1.0:3.9"  # a change, so it runs again
seen, stop = watch(prep, abort_at=0.2)
prep.UpdatePipeline()
stop()
vtkOutputWindow.SetInstance(original_window)
text = messages.GetOutput()
check("stopped on request" in text, "the abort is reported: %r" % text)
partial = [p for p in seen if p < 1.0]
check(partial and partial[-1] < 0.9, "it stopped well before the end of the path: %s" % seen)
check(servermanager.Fetch(prep).GetNumberOfBlocks() == 0 and servermanager.Fetch(prep, idx=1).GetNumberOfRows() == 0,
      "an aborted run leaves empty outputs")
prep.Burr = "cylinder_flat:1.0:4"
prep.UpdatePipeline()
table = servermanager.Fetch(prep, idx=1)
again = {table.GetValue(r, 0).ToString(): table.GetValue(r, 1).ToDouble() for r in range(table.GetNumberOfRows())}
check(again == full, "runs again after the abort: %s vs %s" % (again, full))


def table_of(proxy):
    """The first two columns of the proxy's table output as a dict."""
    table = servermanager.Fetch(proxy, idx=1)
    return {table.GetValue(r, 0).ToString(): table.GetValue(r, 1).ToDouble() for r in range(table.GetNumberOfRows())}


def aborted_run(proxy, abort_at):
    """Runs `proxy` aborting past `abort_at`; the progress seen and the messages logged."""
    window = vtkOutputWindow.GetInstance()
    messages = vtkStringOutputWindow()
    vtkOutputWindow.SetInstance(messages)
    seen, stop = watch(proxy, abort_at=abort_at)
    proxy.UpdatePipeline()
    stop()
    vtkOutputWindow.SetInstance(window)
    return seen, messages.GetOutput()


# Segmentation stops at its next step, not when it has finished.
tooth.VoxelSizemm = 0.121  # a change, so it runs again
seen, text = aborted_run(tooth, abort_at=0.05)
check("stopped on request" in text, "the segmentation's abort is reported: %r" % text)
partial = [p for p in seen if p < 1.0]
check(partial and partial[-1] < 0.9, "segmentation stopped before its level sets were done: %s" % seen)
check(servermanager.Fetch(tooth).GetNumberOfBlocks() == 0, "an aborted segmentation leaves an empty output")
tooth.VoxelSizemm = 0.12
tooth.UpdatePipeline()
check(servermanager.Fetch(tooth).GetNumberOfBlocks() == 3, "segmentation runs again after the abort")

# The assessment of the box against the tooth it was cut from.
assessment = DentalPreparationAssessment(Prepared=prep, Original=tooth, TissueVoxelSizemm=0.12)
seen, stop = watch(assessment)
assessment.UpdatePipeline()
stop()
middle = [p for p in seen if 0.0 < p < 1.0]
print("Assessment progress:", sorted(set(round(p, 2) for p in seen)), len(seen), "events")
check(len(set(middle)) >= 3, "the assessment reports progress along the way: %s" % seen)
rows = table_of(assessment)
check(abs(rows["enamel removed"] / full["enamel"] - 1) < 0.05,
      "the assessment grades the box: %s vs %s" % (rows["enamel removed"], full["enamel"]))
assessment.TissueVoxelSizemm = 0.121
seen, text = aborted_run(assessment, abort_at=0.05)
check("stopped on request" in text, "the assessment's abort is reported: %r" % text)
partial = [p for p in seen if p < 1.0]
check(partial and partial[-1] < 0.9, "the assessment stopped part-way: %s" % seen)
check(servermanager.Fetch(assessment).GetNumberOfPoints() == 0 and servermanager.Fetch(assessment, idx=1).GetNumberOfRows() == 0,
      "an aborted assessment leaves empty outputs")
assessment.TissueVoxelSizemm = 0.12
assessment.UpdatePipeline()
again = table_of(assessment)
check(again == rows, "the assessment runs again after the abort: %s vs %s" % (again, rows))
print("PASSED test_progress_abort")
