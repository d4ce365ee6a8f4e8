"""Shared by the pvbatch tests: argument parsing, the tissue view, baseline comparison."""
import argparse
import os
import shutil
import sys

from paraview import simple

TISSUE_STYLE = {  # colour, opacity: enamel translucent so dentin and pulp show
    "enamel": ((0.96, 0.95, 0.9), 0.35),
    "dentin": ((0.93, 0.8, 0.55), 1.0),
    "pulp": ((0.85, 0.22, 0.22), 1.0),
}


def parse_args():
    parser = argparse.ArgumentParser()
    parser.add_argument("--plugin", required=True)
    parser.add_argument("--baselines", required=True)
    parser.add_argument("--temp", required=True)
    parser.add_argument("--dentsim", help="the dentsim command, for tests that make input files")
    parser.add_argument("--update-baseline", action="store_true")
    return parser.parse_args()


def tissue_view(size=(800, 600)):
    view = simple.CreateView("RenderView")
    view.ViewSize = list(size)
    view.OrientationAxesVisibility = 0
    view.Background = [1.0, 1.0, 1.0]
    try:
        view.UseColorPaletteForBackground = 0
    except AttributeError:
        pass
    view.EnableRenderOnInteraction = 0
    simple.SetActiveView(view)
    return view


def show_blocks(source, view, names):
    """One ExtractBlock per tissue, coloured and made translucent like the demo image."""
    for name in names:
        block = simple.ExtractBlock(Input=source, Selectors=["/Root/" + name])
        display = simple.Show(block, view)
        simple.ColorBy(display, None)
        colour, opacity = TISSUE_STYLE[name]
        display.AmbientColor = list(colour)
        display.DiffuseColor = list(colour)
        display.Opacity = opacity


def place_camera(view):
    view.CameraPosition = [14.0, -22.0, 16.0]
    view.CameraFocalPoint = [0.0, 0.0, 1.5]
    view.CameraViewUp = [0.0, 0.0, 1.0]
    view.CameraParallelScale = 6.0
    view.CameraViewAngle = 30.0


def compare_with_baseline(view, args, name, threshold=15):
    """Renders, saves, and compares with baselines/<name>.png as ParaView's plugin tests do."""
    simple.Render(view)
    image = os.path.join(args.temp, name + ".png")
    simple.SaveScreenshot(image, view, ImageResolution=list(view.ViewSize))
    compare_image(image, args, name, threshold)


def compare_image(image, args, name, threshold=15):
    """Compares a saved picture with baselines/<name>.png (or makes it the baseline with
    --update-baseline)."""
    baseline = os.path.join(args.baselines, name + ".png")
    if args.update_baseline:
        shutil.copyfile(image, baseline)
        print("updated baseline", baseline)
        return
    if not os.path.exists(baseline):
        fail("no baseline " + baseline + " (run with --update-baseline after checking " + image + ")")
    from vtkmodules.vtkIOImage import vtkPNGReader
    from vtkmodules.vtkImagingCore import vtkImageDifference

    readers = []
    for path in (image, baseline):
        reader = vtkPNGReader()
        reader.SetFileName(path)
        reader.Update()
        readers.append(reader)
    diff = vtkImageDifference()
    diff.SetInputConnection(readers[0].GetOutputPort())
    diff.SetImageConnection(readers[1].GetOutputPort())
    diff.Update()
    error = diff.GetThresholdedError()
    print("image difference from baseline %s: %.2f (threshold %s)" % (name, error, threshold))
    if error > threshold:
        fail("image differs from baseline %s by %.2f > %s; see %s" % (baseline, error, threshold, image))


def fail(message):
    # The real stdout: pvbatch may have print() going into a VTK output window.
    sys.__stdout__.write("FAILED: " + message + "\n")
    sys.__stdout__.flush()
    os._exit(1)


def check(condition, message):
    if not condition:
        fail(message)
