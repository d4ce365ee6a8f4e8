"""Renders crates/sim/examples/terracing.rs's output to <folder>/terracing_above.png and terracing_below.png: the segmented
enamel coloured by its normal error against the analytic enamel (0-20 degrees), and beside it the
analytic enamel, both seen from the same side.

    xvfb-run -a -s "-screen 0 1280x1024x24 -noreset" pvbatch plugin/scripts/render_normal_error.py OUT
"""
import os
import sys

from paraview import simple

folder = sys.argv[1]
view = simple.CreateView("RenderView")
view.ViewSize = [1600, 800]
view.Background = [1.0, 1.0, 1.0]
try:
    view.UseColorPaletteForBackground = 0
except AttributeError:
    pass
view.OrientationAxesVisibility = 0

ours = simple.XMLPolyDataReader(FileName=[os.path.join(folder, "enamel.vtp")])
truth = simple.XMLPolyDataReader(FileName=[os.path.join(folder, "analytic_enamel.vtp")])
ours.UpdatePipeline()
bounds = ours.GetDataInformation().GetBounds()
shift = 1.15 * (bounds[1] - bounds[0])
moved = simple.Transform(Input=truth)
moved.Transform.Translate = [shift, 0.0, 0.0]

shown = simple.Show(ours, view)
simple.ColorBy(shown, ("POINTS", "NormalErrorDeg"))
lut = simple.GetColorTransferFunction("NormalErrorDeg")
lut.ApplyPreset("Viridis (matplotlib)", True)
lut.RescaleTransferFunction(0.0, 20.0)
shown.SetScalarBarVisibility(view, True)
bar = simple.GetScalarBar(lut, view)
bar.Title = "normal error (deg)"
bar.ComponentTitle = ""
bar.TitleColor = bar.LabelColor = [0.0, 0.0, 0.0]
plain = simple.Show(moved, view)
plain.ColorArrayName = ["POINTS", ""]
plain.DiffuseColor = [0.85, 0.85, 0.8]

# Seen from above (+z) and from below (-z): one shows the crown's outer surface, the other the
# enamel's inner surface (the dentin-enamel junction) and its cervical edge, whichever jaw.
for name, up in (("terracing_above.png", 1.0), ("terracing_below.png", -1.0)):
    simple.ResetCamera(view)
    camera = view.GetActiveCamera()
    focal, distance = camera.GetFocalPoint(), camera.GetDistance()
    camera.SetPosition(focal[0] + 0.3 * distance, focal[1] - 0.6 * distance, focal[2] + up * 0.75 * distance)
    camera.SetViewUp(0.0, 0.0, up)
    simple.ResetCamera(view)
    simple.SaveScreenshot(os.path.join(folder, name), view, ImageResolution=[1600, 800])
    print("wrote %s" % os.path.join(folder, name))
