"""The default look: a DentSim output shown with a plain Show() is coloured per tissue from the
tissue table (a categorical colour map on the cell array Tissue: enamel translucent, names in the
legend), with no styling by the script."""
import os

from paraview import simple

from dentsim_testing import check, compare_with_baseline, parse_args, place_camera

args = parse_args()
simple.LoadPlugin(args.plugin, ns=globals())

csv = os.path.join(args.temp, "look_groove.csv")
with open(csv, "w") as f:
    f.write("t,x,y,z,qw,qx,qy,qz,cut\n0,-1.5,0,5.6,1,0,0,0,0\n")
    for i in range(31):
        f.write("%.2f,%.2f,0,4.0,1,0,0,0,1\n" % (0.01 * (i + 1), -1.5 + 0.1 * i))

prep = DentalPreparation(PhantomVoxelSizemm=0.08, ToolPathFileCSV=csv)
view = simple.CreateView("RenderView")  # ParaView's own background: only the plugin styles
view.ViewSize = [800, 600]
view.OrientationAxesVisibility = 0
display = simple.Show(prep, view)
check(display.ColorArrayName[1] == "Tissue", "coloured by Tissue: %s" % display.ColorArrayName)
lut = display.LookupTable
check(lut.InterpretValuesAsCategories == 1, "the Tissue colour map is categorical")
annotations = dict(zip(lut.Annotations[0::2], lut.Annotations[1::2]))
check({"enamel", "dentin", "pulp"} <= set(annotations.values()), "legend names tissues: %s" % annotations)
by_name = {name: i for i, name in enumerate(lut.Annotations[1::2])}
opacity = {name: lut.IndexedOpacities[i] for name, i in by_name.items()}
check(lut.EnableOpacityMapping == 1 and opacity["enamel"] < 1.0 and opacity["dentin"] == 1.0,
      "enamel translucent, dentin opaque: %s" % opacity)
# The colours are the tissue table's, as each block's field data Colour carries them.
data = simple.servermanager.Fetch(prep)
for b in range(data.GetNumberOfBlocks()):
    block = data.GetBlock(b)
    name = block.GetFieldData().GetAbstractArray("TissueName").GetValue(0)
    colour = block.GetFieldData().GetArray("Colour").GetTuple3(0)
    i = by_name[name]
    mapped = lut.IndexedColors[3 * i:3 * i + 3]
    check(all(abs(a - b) < 1e-6 for a, b in zip(colour, mapped)), "%s colour %s vs %s" % (name, colour, mapped))
display.SetScalarBarVisibility(view, True)
place_camera(view)
compare_with_baseline(view, args, "default_look")
print("PASSED test_default_look")
