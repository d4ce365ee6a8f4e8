"""The Dental Haptic Session as a clinician meets it: Apply with the defaults works (the
simulated hand on the built-in phantom), the session streams on plain UpdatePipeline() calls,
the burr and force arrow carry their own colours, the force over time is a table the Line Chart
view shows, Pause holds it, Stop ends the session and the log is written; the device list offers the SpaceMouse
and OpenIGTLink, whose absence is reported by name."""
import os
import time

from paraview import servermanager, simple
from vtkmodules.vtkCommonCore import vtkOutputWindow, vtkStringOutputWindow

from dentsim_testing import check, parse_args

args = parse_args()
simple.LoadPlugin(args.plugin, ns=globals())

log = os.path.join(args.temp, "clinician_session.dslog")
if os.path.exists(log):
    os.remove(log)

# Every property at its default, as after pressing Apply; only the log is asked for, and a hand
# that keeps going for two minutes instead of ten seconds: Stop must come before the hand's end,
# and on a loaded machine the steps below took more than ten seconds (the session had ended).
default_hand = "start=0:0:5.6,target=0:0:2.5,push=1,pedal=1,duration=10"
session = DentalHapticSession(SessionLog=log)
check(session.Device == "Simulated hand", "default device: %s" % session.Device)
check(session.HandParameters == default_hand, "default hand: %s" % session.HandParameters)
session.HandParameters = default_hand.replace("duration=10", "duration=120")


def blocks(data):
    names = [data.GetMetaData(i).Get(data.NAME()) for i in range(data.GetNumberOfBlocks())]
    return dict(zip(names, (data.GetBlock(i) for i in range(data.GetNumberOfBlocks()))))


# Streams with nothing but UpdatePipeline(): each call shows a later tick while it runs.
ticks = []
for _ in range(300):
    session.UpdatePipeline()
    data = servermanager.Fetch(session)
    ticks.append(int(data.GetFieldData().GetArray("Tick").GetValue(0)))
    if len(set(ticks)) >= 4 and ticks[-1] > 1500:
        break
    time.sleep(0.05)
print("ticks seen on plain updates:", sorted(set(ticks))[:6], "...", ticks[-1])
check(len(set(ticks)) >= 4 and ticks == sorted(ticks), "the session streamed: %s" % ticks[-10:])

b = blocks(data)
check(set(["enamel", "dentin", "pulp", "burr", "force"]) <= set(b), "blocks: %s" % list(b))
burr_colour = b["burr"].GetPointData().GetArray("Colour").GetTuple3(0)
force_colour = b["force"].GetPointData().GetArray("Colour").GetTuple3(0)
check(burr_colour == (140.0, 150.0, 170.0) and force_colour == (220.0, 30.0, 30.0),
      "own colours: burr %s, force %s" % (burr_colour, force_colour))
check(b["enamel"].GetFieldData().GetArray("RemovedVolume") is not None, "removed volume per tissue")

# The force over time: output port 1, one row per update that saw a new tick.
history = servermanager.Fetch(session, idx=1)
rows = history.GetNumberOfRows()
times = [history.GetColumnByName("Time").GetValue(i) for i in range(rows)]
forces = [history.GetColumnByName("Force").GetValue(i) for i in range(rows)]
print("force history: %d rows, t %.3f..%.3f s, max %.3f N" % (rows, times[0], times[-1], max(forces)))
check(rows >= 4 and times == sorted(times) and times[-1] > times[0], "history rows: %d" % rows)
check(max(forces) > 0.1, "the hand pressed on the tooth: max %.3f N" % max(forces))
chart = simple.CreateView("XYChartView")
line = simple.Show(simple.OutputPort(session, 1), chart)
line.UseIndexForXAxis = 0
line.XArrayName = "Time"
line.SeriesVisibility = ["Force"]
simple.Render(chart)

# Pause: the picture holds (nothing is logged) while the session's clock goes on; then resume.
session.Pause = 1
session.UpdatePipeline()
time.sleep(0.05)
session.UpdatePipeline()
held = int(servermanager.Fetch(session).GetFieldData().GetArray("Tick").GetValue(0))
time.sleep(0.3)
session.UpdatePipeline()
still = int(servermanager.Fetch(session).GetFieldData().GetArray("Tick").GetValue(0))
check(still == held, "paused: tick %d then %d" % (held, still))
session.Pause = 0
for _ in range(100):
    time.sleep(0.05)
    session.UpdatePipeline()
    resumed = int(servermanager.Fetch(session).GetFieldData().GetArray("Tick").GetValue(0))
    if resumed > held:
        break
check(resumed > held + 200, "resumed past the pause: tick %d after %d" % (resumed, held))

# Stop: the session ends now, the final tissues are shown and the log is complete.
session.SMProxy.InvokeCommand("Stop")
session.UpdatePipeline()
data = servermanager.Fetch(session)
check(data.GetFieldData().GetArray("Running").GetValue(0) == 0.0, "stopped")
stopped_at = int(data.GetFieldData().GetArray("Tick").GetValue(0))
check(stopped_at < 120000, "stopped before the hand's 120 s: tick %d" % stopped_at)
check(os.path.getsize(log) > 1000, "log written: %d bytes" % os.path.getsize(log))
simple.Delete(session)

# The device list: a SpaceMouse or an OpenIGTLink bridge that is not there is reported by name.
messages = vtkStringOutputWindow()
original = vtkOutputWindow.GetInstance()
vtkOutputWindow.SetInstance(messages)
mouse = DentalHapticSession(PhantomVoxelSizemm=0.1, Device="SpaceMouse")
mouse.UpdatePipeline()
arm = DentalHapticSession(PhantomVoxelSizemm=0.1, Device="OpenIGTLink",
                          OpenIGTLinkURL="igtl://127.0.0.1:9?connect=100")
arm.UpdatePipeline()
vtkOutputWindow.SetInstance(original)
text = messages.GetOutput()
check("no SpaceMouse plugged in" in text, "SpaceMouse absence reported: %r" % text)
check("127.0.0.1:9" in text and "cannot connect" in text, "OpenIGTLink absence reported: %r" % text)

# A live device shows where its workspace sits on the scan: a pyigtl bridge (PyPI) sends the
# stylus at the device origin, which the default registration puts 1 mm above the tooth's top.
import socket
import threading

import numpy as np
import pyigtl

probe = socket.socket()
probe.bind(("127.0.0.1", 0))
port = probe.getsockname()[1]
probe.close()
bridge = pyigtl.OpenIGTLinkServer(port=port, local_server=True)
sending = True


def send_poses():
    while sending:
        if bridge.is_connected():
            bridge.send_message(pyigtl.TransformMessage(np.eye(4), device_name="Stylus"), wait=True)
        time.sleep(0.01)


threading.Thread(target=send_poses, daemon=True).start()
arm = DentalHapticSession(PhantomVoxelSizemm=0.1, Device="OpenIGTLink",
                          OpenIGTLinkURL="igtl://127.0.0.1:%d?pose=Stylus" % port)
for _ in range(200):
    arm.UpdatePipeline()
    # One fetch per look: while the session runs each fetch shows a newer state.
    data = servermanager.Fetch(arm)
    b = blocks(data)
    if "workspace" in b and int(data.GetFieldData().GetArray("Tick").GetValue(0)) > 0:
        break
    time.sleep(0.05)
check("workspace" in b, "a live device's workspace block: %s" % list(b))
wb = b["workspace"].GetBounds()
centre = [(wb[0] + wb[1]) / 2, (wb[2] + wb[3]) / 2, (wb[4] + wb[5]) / 2]
radius = (wb[1] - wb[0]) / 2
top = max(b[t].GetBounds()[5] for t in ("enamel", "dentin", "pulp"))
print("workspace centre %s, radius %.1f mm, tooth top %.2f mm" % ([round(c, 2) for c in centre], radius, top))
check(abs(centre[2] - (top + 1.0)) < 0.15 and abs(centre[0]) < 0.3 and abs(centre[1]) < 0.3,
      "centred on the tooth: %s, top %.2f" % (centre, top))
check(abs(radius - 100.0) < 0.5, "the desktop profile's 100 mm reach: %.2f" % radius)
check(b["workspace"].GetPointData().GetArray("Colour").GetTuple3(0) == (60.0, 120.0, 220.0), "own colour")
burr_bottom = b["burr"].GetBounds()[4]
check(abs(burr_bottom - (top + 1.0)) < 0.6, "the stylus at the origin holds the burr above the crown: %.2f" % burr_bottom)
arm.SMProxy.InvokeCommand("Stop")
arm.UpdatePipeline()
sending = False
bridge.stop()
print("PASSED test_haptic_session_clinician")
