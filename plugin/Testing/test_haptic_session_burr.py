"""The Dental Haptic Session's Burr property: the session cuts with the burr named (here a flat
cylinder, drawn as one), and a bad spec is reported as a VTK error naming the burr."""
from paraview import servermanager, simple
from vtkmodules.vtkCommonCore import vtkOutputWindow, vtkStringOutputWindow

from dentsim_testing import check, parse_args

args = parse_args()
simple.LoadPlugin(args.plugin, ns=globals())

session = DentalHapticSession(PhantomVoxelSizemm=0.1, Device="Simulated hand",
                              HandParameters="start=0:0:5.8,target=0:0:4.0,push=1,pedal=1,duration=0.3",
                              Burr="cylinder_flat:1.2:3", RealTime=0)


def fetch(source):
    source.SMProxy.InvokeCommand("PollSession")
    source.SMProxy.MarkModified(source.SMProxy)
    source.UpdatePipeline()
    data = servermanager.Fetch(source)
    names = [data.GetMetaData(i).Get(data.NAME()) for i in range(data.GetNumberOfBlocks())]
    return data, dict(zip(names, (data.GetBlock(i) for i in range(data.GetNumberOfBlocks()))))


data, blocks = fetch(session)
while data.GetFieldData().GetArray("Running").GetValue(0) == 1.0:
    data, blocks = fetch(session)
b = blocks["burr"].GetBounds()
print("burr bounds:", b, "contact:", data.GetFieldData().GetAbstractArray("ContactTissue").GetValue(0))
check(abs((b[5] - b[4]) - 3.0) < 0.1 and abs((b[1] - b[0]) - 1.2) < 0.1, "the burr drawn is the cylinder: %s" % (b,))
check(data.GetFieldData().GetAbstractArray("ContactTissue").GetValue(0) == "enamel", "it cut into the enamel")

original_window = vtkOutputWindow.GetInstance()
messages = vtkStringOutputWindow()
vtkOutputWindow.SetInstance(messages)
session.Burr = "cone:1"
session.UpdatePipeline()
vtkOutputWindow.SetInstance(original_window)
text = messages.GetOutput()
print("reported:", text.strip().splitlines()[0] if text.strip() else "")
check("DentSim" in text and "burr 'cone:1'" in text and "shape 'cone'" in text, "error names the burr: %r" % text)
print("PASSED test_haptic_session_burr")
