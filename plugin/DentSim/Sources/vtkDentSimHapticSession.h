// "Dental Haptic Session": a ParaView live source over a dentsim haptic session running in the
// background (Rust threads; the haptic tick never waits on VTK). Each update polls the latest
// state and outputs a multiblock: one block per tissue surface, `burr` (the burr head at the
// proxy), `force` (a line from the burr centre along the rendered force, 10 mm per N, point array
// `Force` in N) and field data `ContactTissue`, `Tick`, `Time` (s). Lengths in mm.
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
  // 0: scripted tool path (ScriptedPath, CSV); 1: simulated hand (HandParameters).
  vtkSetClampMacro(DeviceKind, int, 0, 1);
  vtkGetMacro(DeviceKind, int);
  vtkSetStringMacro(ScriptedPath);
  vtkGetStringMacro(ScriptedPath);
  vtkSetStringMacro(HandParameters);
  vtkGetStringMacro(HandParameters);
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

protected:
  vtkDentSimHapticSession();
  ~vtkDentSimHapticSession() override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  char* TissuesFile = nullptr;
  double PhantomVoxelSize = 0.05;
  int DeviceKind = 0;
  char* ScriptedPath = nullptr;
  char* HandParameters = nullptr;
  char* Profile = nullptr;
  char* Filter = nullptr;
  char* Burr = nullptr;
  bool RealTime = true;

private:
  vtkDentSimHapticSession(const vtkDentSimHapticSession&) = delete;
  void operator=(const vtkDentSimHapticSession&) = delete;
  struct Internals;
  Internals* Internal;
};
