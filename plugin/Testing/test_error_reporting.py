"""Bad parameters reach ParaView as VTK errors naming the field; ParaView stays up and recovers."""
from paraview import servermanager, simple
from vtkmodules.vtkCommonCore import vtkOutputWindow, vtkStringOutputWindow

from dentsim_testing import check, parse_args

args = parse_args()
# LoadPlugin puts the proxies named by their XML labels into this namespace.
simple.LoadPlugin(args.plugin, ns=globals())

# pvbatch routes print() through the output window too, so capture only around the updates.
original_window = vtkOutputWindow.GetInstance()
messages = vtkStringOutputWindow()
vtkOutputWindow.SetInstance(messages)

source = DentalPhantomStroke(VoxelSizemm=0.1)
source.BurrDiametermm = -1.0
source.UpdatePipeline()
text = messages.GetOutput()
check("DentSim" in text and "burr diameter" in text, "error names the burr diameter: %r" % text)

source.BurrDiametermm = 1.0
source.StrokeStartmm = [float("nan"), 0.0, 4.2]
source.UpdatePipeline()
check("stroke start" in messages.GetOutput(), "error names the stroke start")
vtkOutputWindow.SetInstance(original_window)
print("reported:", messages.GetOutput().strip().splitlines()[0])

# Still alive: a valid request afterwards produces the tissues.
source.StrokeStartmm = [-2.0, 0.0, 4.2]
source.UpdatePipeline()
data = servermanager.Fetch(source)
check(data.GetNumberOfBlocks() == 3, "recovers after errors")
print("PASSED test_error_reporting")
