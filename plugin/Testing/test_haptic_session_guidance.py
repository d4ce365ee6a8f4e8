"""Live guidance in the Dental Haptic Session: a simulated hand drills the phantom toward its pulp
(top at z = 2.0). The output's field data carries the remaining dentin, the warning level and the
events; the burr's Colour turns amber near the pulp and magenta-red inside it."""
from paraview import servermanager, simple

from dentsim_testing import check, parse_args

args = parse_args()
simple.LoadPlugin(args.plugin, ns=globals())


def state(source):
    """Polls like ParaView's live-source timer and returns the guidance figures."""
    source.SMProxy.InvokeCommand("PollSession")
    source.SMProxy.MarkModified(source.SMProxy)
    source.UpdatePipeline()
    data = servermanager.Fetch(source)
    names = [data.GetMetaData(i).Get(data.NAME()) for i in range(data.GetNumberOfBlocks())]
    burr = data.GetBlock(names.index("burr"))
    fd = data.GetFieldData()
    value = lambda name: fd.GetArray(name).GetValue(0)
    return {
        "running": value("Running") == 1.0,
        "tick": int(value("Tick")),
        "dentin": value("RemainingDentinMm"),
        "level": int(value("GuidanceLevel")),
        "threshold": value("ThinDentinThresholdMm"),
        "thin_events": int(value("ThinDentinEvents")),
        "exposures": int(value("PulpExposureEvents")),
        "colour": tuple(int(c) for c in burr.GetPointData().GetArray("Colour").GetTuple3(0)),
        "burr_level": int(burr.GetFieldData().GetArray("GuidanceLevel").GetValue(0)),
        "burr_label": int(burr.GetCellData().GetArray("Tissue").GetValue(0)),
        "force_label": int(data.GetBlock(names.index("force")).GetCellData().GetArray("Tissue").GetValue(0)),
    }


# The hand starts 100 mm above the tooth: 1.5 s in the air at its 67 mm/s (push over damping).
# In real time the first poll must see the burr still far from the pulp, and on a loaded machine
# ParaView's first poll has answered 1.1 s into the session (started 0.6 mm above the tooth, the
# burr was within reading range 0.9 s in).
hand = "start=0:0:105.6,target=0:0:1.0,push=2,pedal=1,rpm=400000,duration=4.5"
session = DentalHapticSession(PhantomVoxelSizemm=0.08, Device="Simulated hand", HandParameters=hand,
                              ForceFilter="none", RealTime=1)
seen = [state(session)]
while seen[-1]["running"]:
    seen.append(state(session))
final = seen[-1]
print("polls %d; final %s" % (len(seen), final))
check(final["tick"] == 4501 and not final["running"], "ran to the end: %s" % final)
check(final["threshold"] == 0.5, "threshold: %s" % final)
check(final["thin_events"] >= 1 and final["exposures"] >= 1, "events: %s" % final)
check(final["level"] == 2 and final["dentin"] < 0.0 and final["burr_level"] == 2, "in the pulp at the end: %s" % final)
check(final["colour"] == (230, 0, 120), "the burr is magenta-red in the pulp: %s" % (final["colour"],))
first = seen[0]
check(first["colour"] == (140, 150, 170) and first["level"] == 0, "steel when clear: %s" % first)
check(first["dentin"] != first["dentin"], "no reading far from the pulp (NaN): %s" % first)
# The default colour map (categorical on Tissue) names the burr by its warning and the force.
check(first["burr_label"] == 0 and final["burr_label"] == -2 and final["force_label"] == -3,
      "labels: clear %d, in the pulp %d, force %d" % (first["burr_label"], final["burr_label"], final["force_label"]))
lut = simple.GetColorTransferFunction("Tissue")
annotations = list(lut.Annotations)
for label, name in (("0", "burr"), ("-1", "burr near the pulp"), ("-2", "burr in the pulp"), ("-3", "force")):
    check(label in annotations[0::2] and annotations[annotations.index(label) + 1] == name,
          "the Tissue colour map names %s: %s" % (name, annotations))
