"""Run inside the ParaView GUI by test_gui_workflow.py (paraview --test-script): the main
workflow as a user does it in the GUI: a CBCT opened with ParaView's reader, Dental Tissues From
Scan, Dental Preparation on its output with a tool path file, shown with the plugin's default
look; the window is saved for comparison with a baseline."""
import os

from paraview import servermanager, simple

temp = os.environ["DENTSIM_GUI_TEMP"]
result = os.path.join(temp, "gui_workflow.result")
try:
    simple.SetActiveSource(None)
    scan = simple.OpenDataFile(os.path.join(temp, "gui_scan.mha"))
    simple.SetActiveSource(scan)
    tooth = simple.DentalTissuesFromScan(Input=scan, VoxelSizemm=0.1, UseSeedPoint=1, SeedPointmm=[24.0, 18.0, -33.0])
    simple.SetActiveSource(tooth)  # what the pipeline browser does: the new filter is selected
    prep = simple.DentalPreparation(Tissues=tooth, TissueVoxelSizemm=0.1,
                                    ToolPathFileCSV=os.path.join(temp, "gui_groove.csv"))
    simple.SetActiveSource(prep)
    assert prep.ToolPath is None or len(prep.ToolPath) == 0, "ToolPath bound by surprise"
    view = simple.GetActiveViewOrCreate("RenderView")
    display = simple.Show(prep, view)
    simple.Hide(tooth, view)
    display.SetScalarBarVisibility(view, True)
    view.OrientationAxesVisibility = 0
    view.CameraPosition = [38.0, 0.0, -14.0]
    view.CameraFocalPoint = [24.0, 18.0, -31.0]
    view.CameraViewUp = [0.0, 0.0, 1.0]
    simple.ResetCamera(view)
    simple.Render(view)
    table = servermanager.Fetch(prep, idx=1)
    removed = {table.GetValue(r, 0).ToString(): table.GetValue(r, 1).ToDouble() for r in range(table.GetNumberOfRows())}
    assert removed.get("enamel", 0) > 0.5, removed
    assert display.LookupTable.InterpretValuesAsCategories == 1, "the Tissue colour map is categorical"
    simple.SaveScreenshot(os.path.join(temp, "gui_workflow.png"), view, ImageResolution=[800, 600])
    with open(result, "w") as f:
        f.write("PASSED %s\n" % removed)
except Exception as e:  # the driver reads the result; the GUI would only log it
    with open(result, "w") as f:
        f.write("FAILED %r\n" % (e,))
os._exit(0)  # a startup script cannot close the window otherwise
