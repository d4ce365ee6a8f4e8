"""Run by test_gui_clicks.py in pvbatch: the state the clicks saved holds the pipeline as clicked
(reader -> Dental Tissues From Scan -> Dental Preparation through its Tissues input; Apply hid
the uncut tooth, as ParaView hides a filter's input) and its preparation removes what the same pipeline built in Python removes."""
import os

from paraview import servermanager, simple

from dentsim_testing import check, parse_args

args = parse_args()
simple.LoadPlugin(args.plugin, ns=globals())
simple.LoadState(os.path.join(args.temp, "clicked.pvsm"))

prep = simple.FindSource("DentalPreparation1")
tooth = simple.FindSource("DentalTissuesFromScan1")
reader = simple.FindSource("clicks_scan.mha")
check(prep is not None and tooth is not None and reader is not None, "the clicked pipeline is in the state")
check(prep.Tissues.GetAddressAsString("") == tooth.GetAddressAsString(""), "Tissues was chosen in the input selector")
check(prep.ToolPath is None or len(prep.ToolPath) == 0, "nothing was bound to Tool Path")
check(tooth.Input.GetAddressAsString("") == reader.GetAddressAsString(""), "the filter runs on the reader")
check(prep.ToolPathFileCSV.endswith("clicks_groove.csv") and prep.Burr == "round:1.2", "typed properties kept")
view = simple.GetActiveView()
check(not simple.GetDisplayProperties(tooth, view).Visibility and simple.GetDisplayProperties(prep, view).Visibility,
      "the uncut tooth is hidden, the preparation shows")


def removed(source):
    source.UpdatePipeline()
    table = servermanager.Fetch(source, idx=1)
    return {table.GetValue(r, 0).ToString(): table.GetValue(r, 1).ToDouble() for r in range(table.GetNumberOfRows())}


clicked = removed(prep)
scan = simple.OpenDataFile(os.path.join(args.temp, "clicks_scan.mha"))
typed = DentalTissuesFromScan(Input=scan, VoxelSizemm=0.08, UseSeedPoint=1, SeedPointmm=list(tooth.SeedPointmm))
scripted = removed(DentalPreparation(Tissues=typed, TissueVoxelSizemm=0.08, Burr="round:1.2",
                                            ToolPathFileCSV=prep.ToolPathFileCSV))
print("clicked:", clicked)
print("scripted:", scripted)
check(clicked.get("enamel", 0) > 0.5, "the clicked groove removed enamel: %s" % clicked)
check(clicked == scripted, "clicks and script give the same preparation: %s vs %s" % (clicked, scripted))
print("PASSED test_gui_clicks")
