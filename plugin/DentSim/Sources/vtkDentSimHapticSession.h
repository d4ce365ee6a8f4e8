// "Dental Haptic Session": a ParaView live source over a dentsim haptic session running in the
// background (Rust threads; the haptic tick never waits on VTK). Each update polls the latest
// state and outputs a multiblock: one block per tissue surface, `burr` (the burr head at the
// proxy), `force` (a line from the burr centre along the rendered force, 10 mm per N, point array
// `Force` in N) and field data `ContactTissue`, `Tick`, `Time` (s). Lengths in mm. The burr and
// the force arrow carry an RGB point array `Colour` (steel grey, red) of their own. With a live
// device (SpaceMouse, OpenIGTLink) a block `workspace` (blue circles) shows where the device's
// workspace sits on the scan (the registration; centred on the tooth by default). Output port 1
// is the force over time (a table: Time, Force, Fx, Fy, Fz, ContactTissue) for a Line Chart view.
// While the session runs, every update (the GUI's live-source timer, or UpdatePipeline() in
// pvpython) shows its latest state: no other call is needed.
#pragma once

#include <vtkMultiBlockDataSetAlgorithm.h>

#include "DentSimSourcesModule.h"

#include <string>

class DENTSIMSOURCES_EXPORT vtkDentSimHapticSession : public vtkMultiBlockDataSetAlgorithm {
public:
  static vtkDentSimHapticSession* New();
  vtkTypeMacro(vtkDentSimHapticSession, vtkMultiBlockDataSetAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  // Tissues (.vdb); empty for the built-in capsule phantom.
  vtkSetStringMacro(TissuesFile);
  vtkGetStringMacro(TissuesFile);
  vtkSetMacro(PhantomVoxelSize, double);
  vtkGetMacro(PhantomVoxelSize, double);
  // 0: scripted tool path (ScriptedPath, CSV); 1: simulated hand (HandParameters, the default:
  // it works on Apply); 2: SpaceMouse (SpaceMouseParameters); 3: OpenIGTLink (OpenIGTLinkURL).
  vtkSetClampMacro(DeviceKind, int, 0, 3);
  vtkGetMacro(DeviceKind, int);
  vtkSetStringMacro(ScriptedPath);
  vtkGetStringMacro(ScriptedPath);
  vtkSetStringMacro(HandParameters);
  vtkGetStringMacro(HandParameters);
  vtkSetStringMacro(SpaceMouseParameters);
  vtkGetStringMacro(SpaceMouseParameters);
  vtkSetStringMacro(OpenIGTLinkURL);
  vtkGetStringMacro(OpenIGTLinkURL);
  // A USB foot pedal as the cut switch of any device, typing PedalKey while held.
  vtkSetMacro(FootPedal, bool);
  vtkGetMacro(FootPedal, bool);
  vtkSetStringMacro(PedalKey);
  vtkGetStringMacro(PedalKey);
  // Where the session log goes; empty for none.
  vtkSetStringMacro(SessionLog);
  vtkGetStringMacro(SessionLog);
  vtkSetStringMacro(Profile);
  vtkGetStringMacro(Profile);
  vtkSetStringMacro(Filter);
  vtkGetStringMacro(Filter);
  // A burr spec as the preparation's Burr: catalogue name, ISO number or SHAPE:DIAMETER_MM[:LENGTH_MM].
  vtkSetStringMacro(Burr);
  vtkGetStringMacro(Burr);
  vtkSetMacro(RealTime, bool);
  vtkGetMacro(RealTime, bool);

  // For ParaView's live-source timer: true (and Modified) while the session may have news.
  bool GetNeedsUpdate();
  // Ends the session now: the log is completed and the final tissues shown.
  void Stop();
  // Paused: zero force, nothing cut or logged, the picture holds; the session is not restarted.
  vtkSetMacro(Paused, bool);
  vtkGetMacro(Paused, bool);
  // While a session runs, the pipeline sees this source as modified at every update, so each
  // UpdatePipeline() shows the latest state.
  vtkMTimeType GetMTime() override;

protected:
  vtkDentSimHapticSession();
  ~vtkDentSimHapticSession() override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int FillOutputPortInformation(int port, vtkInformation* info) override;

  char* TissuesFile = nullptr;
  double PhantomVoxelSize = 0.05;
  int DeviceKind = 1;
  char* ScriptedPath = nullptr;
  char* HandParameters = nullptr;
  char* SpaceMouseParameters = nullptr;
  char* OpenIGTLinkURL = nullptr;
  bool FootPedal = false;
  char* PedalKey = nullptr;
  char* SessionLog = nullptr;
  char* Profile = nullptr;
  char* Filter = nullptr;
  char* Burr = nullptr;
  bool RealTime = true;
  bool Paused = false;

private:
  vtkDentSimHapticSession(const vtkDentSimHapticSession&) = delete;
  void operator=(const vtkDentSimHapticSession&) = delete;
  struct Internals;
  Internals* Internal;
};
