"""The Dental Haptic Session live source with a scripted device: it advances while polled, shows
the burr, the force and the tissue in contact, and ends on a reproducible picture."""
import os
import time

from paraview import servermanager, simple

from dentsim_testing import (check, compare_with_baseline, parse_args, place_camera, show_blocks,
                             tissue_view)

args = parse_args()
simple.LoadPlugin(args.plugin, ns=globals())


def write_path(name, held_until):
    """Down into the phantom's top (z = 5.0) with the pedal held, held 0.3 mm deep until
    `held_until` while the burr cuts its way down at the enamel's removal rate, then pedal up and
    pressing 0.2 mm on; ends 0.2 s after."""
    rows = [(0.0, 6.0, 1), (0.4, 4.7, 1), (held_until, 4.7, 1), (held_until + 0.05, 4.7, 0), (held_until + 0.2, 4.5, 0)]
    path = os.path.join(args.temp, name)
    with open(path, "w") as f:
        f.write("t,x,y,z,qw,qx,qy,qz,rpm,cut\n")
        f.writelines("%g,0,0,%g,1,0,0,0,200000,%d\n" % row for row in rows)
    return path


path = write_path("haptic_session_path.csv", 1.0)


def state(source):
    """Polls like ParaView's live-source timer, updates, and returns the output's figures."""
    source.SMProxy.InvokeCommand("PollSession")  # GetNeedsUpdate(): Modified() while running
    source.SMProxy.MarkModified(source.SMProxy)
    source.UpdatePipeline()
    data = servermanager.Fetch(source)
    names = [data.GetMetaData(i).Get(data.NAME()) for i in range(data.GetNumberOfBlocks())]
    blocks = dict(zip(names, (data.GetBlock(i) for i in range(data.GetNumberOfBlocks()))))
    fd = data.GetFieldData()
    bounds = blocks["burr"].GetBounds()
    force = blocks["force"].GetPointData().GetArray("Force").GetTuple3(0)
    return {
        "names": names,
        "running": fd.GetArray("Running").GetValue(0) == 1.0,
        "tick": int(fd.GetArray("Tick").GetValue(0)),
        "contact": fd.GetAbstractArray("ContactTissue").GetValue(0),
        "burr_bottom": bounds[4],
        "force": force,
        "force_norm": sum(c * c for c in force) ** 0.5,
    }


# Real time: the session runs on its own clock while we poll. The same motion held 2 s longer in
# the cut: a loaded machine answers a poll in up to a second (the haptic thread keeps a core), and
# the 1.2 s path then ended before a second poll.
live_path = write_path("haptic_session_path_live.csv", 3.0)
live = DentalHapticSession(PhantomVoxelSizemm=0.08, Device="Scripted tool path", ScriptedPathCSV=live_path,
                           ForceFilter="none", RealTime=1)
seen = []
for _ in range(200):
    s = state(live)
    seen.append(s)
    if not s["running"]:
        break
    time.sleep(0.1)
running_ticks = sorted({s["tick"] for s in seen if s["running"]})
print("real-time polls: %d, ticks seen while running: %s" % (len(seen), running_ticks[:8]))
check(seen[0]["names"] == ["enamel", "dentin", "pulp", "burr", "force"], "blocks: %s" % seen[0]["names"])
check(len(running_ticks) >= 2, "the session advanced between polls: %s" % running_ticks)
final = seen[-1]
check(not final["running"] and final["tick"] == 3201, "ran to the end of the path: %s" % final)
check(4.6 < final["burr_bottom"] < 4.95, "burr moved down into the top: %s" % final)
check(final["contact"] == "enamel", "contact tissue: %r" % final["contact"])
# The force itself is checked on the back-to-back run below: in real time on a loaded machine the
# watchdog may have ramped it to zero after missed deadlines, as it should.
simple.Delete(live)

# Not real time: the same path ticked back to back ends on the same state every run.
batch = DentalHapticSession(PhantomVoxelSizemm=0.08, Device="Scripted tool path", ScriptedPathCSV=path,
                            ForceFilter="none", RealTime=0)
s = state(batch)
while s["running"]:
    time.sleep(0.05)
    s = state(batch)
print("final state: tick %d, burr bottom %.3f mm, force %s N, contact %s"
      % (s["tick"], s["burr_bottom"], tuple(round(c, 3) for c in s["force"]), s["contact"]))
check(s["tick"] == 1201 and s["contact"] == "enamel" and s["force_norm"] > 0.1, "batch final: %s" % s)

view = tissue_view()
show_blocks(batch, view, ["enamel", "dentin", "pulp"])
burr = simple.Show(simple.ExtractBlock(Input=batch, Selectors=["/Root/burr"]), view)
simple.ColorBy(burr, None)
burr.DiffuseColor = [0.55, 0.6, 0.7]
arrow = simple.ExtractBlock(Input=batch, Selectors=["/Root/force"])
arrow_data = servermanager.Fetch(arrow)
print("force arrow bounds:", arrow_data.GetBlock(0).GetBounds() if arrow_data.GetNumberOfBlocks() else None)
force = simple.Show(simple.Tube(Input=simple.ExtractSurface(Input=simple.MergeBlocks(Input=arrow)), Radius=0.08), view)
force.Representation = "Surface"
simple.ColorBy(force, ("POINTS", "Force", "Magnitude"))
force.LookupTable.RescaleTransferFunction(0.0, 0.5)
place_camera(view)
compare_with_baseline(view, args, "haptic_session")
print("PASSED test_haptic_session")
