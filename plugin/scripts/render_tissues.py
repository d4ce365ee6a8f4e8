"""Renders the tissue surfaces in a dentsim output folder to <folder>/tissues.png.

Run under pvbatch with a display (xvfb-run on a headless machine):
    xvfb-run -a -s "-screen 0 1280x1024x24 -noreset" pvbatch plugin/scripts/render_tissues.py OUT
Each <tissue>.vtp carries its colour and opacity as field data; enamel is translucent so the
dentin and pulp beneath, and the preparation through them, show.
"""
import glob
import os
import sys

from paraview import servermanager, simple

folder = sys.argv[1]
vtps = sorted(glob.glob(os.path.join(folder, "*.vtp")))
if not vtps:
    sys.__stderr__.write("render_tissues: no .vtp files in %s\n" % folder)
    sys.exit(1)

view = simple.CreateView("RenderView")
view.ViewSize = [1200, 900]
view.OrientationAxesVisibility = 1
view.Background = [1.0, 1.0, 1.0]
try:
    view.UseColorPaletteForBackground = 0
except AttributeError:
    pass

for path in vtps:
    reader = simple.XMLPolyDataReader(FileName=[path])
    fields = servermanager.Fetch(reader).GetFieldData()
    display = simple.Show(reader, view)
    simple.ColorBy(display, None)
    colour = fields.GetArray("Colour")
    if colour is not None:
        display.DiffuseColor = list(colour.GetTuple3(0))
        display.AmbientColor = list(colour.GetTuple3(0))
    opacity = fields.GetArray("Opacity")
    if opacity is not None:
        display.Opacity = opacity.GetValue(0)
    display.Specular = 0.3

simple.ResetCamera(view)
camera = view.GetActiveCamera()
focal = camera.GetFocalPoint()
distance = camera.GetDistance()
# From buccal and above, crown up (+Z), like a dentist looking at the occlusal preparation.
direction = (0.45, -0.7, 0.55)
norm = sum(c * c for c in direction) ** 0.5
view.CameraPosition = [focal[i] + distance * direction[i] / norm for i in range(3)]
view.CameraViewUp = [0.0, 0.0, 1.0]
simple.ResetCamera(view)
out = os.path.join(folder, "tissues.png")
simple.SaveScreenshot(out + ".tmp.png", view, ImageResolution=view.ViewSize)
os.replace(out + ".tmp.png", out)
sys.__stdout__.write("rendered %s\n" % out)
