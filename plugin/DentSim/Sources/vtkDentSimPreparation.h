// "Dental Preparation": cuts a tool path into tissues with a burr, all in the Rust core.
// Tissues: the optional input on port 1 (a multiblock of tissue surfaces named by tissue, e.g.
// Tissues From Scan's or the reader's output, rebuilt as level sets at TissueVoxelSize), else the
// .vdb at TissuesFile (level sets named by tissue), else the built-in capsule phantom. Port 0 is
// never connected: ParaView binds a new proxy's port-0 input to the active source, and neither
// input may be bound by surprise. Tool path: the optional input on port 2 (a vtkPolyData polyline whose points carry
// `Orientation`, 4 components w,x,y,z, and optionally `Time` (s), `RPM`, `Cut` (0/1)), else the
// CSV at ToolPathFile (t,x,y,z,qw,qx,qy,qz[,rpm][,cut]). Burr: a spec (`round:1.0`, an ISO
// number, a catalogue name). Force 0 cuts geometrically; above 0 (N) the cut is rate-limited by
// the tissue table. Output 0: one block per tissue (as the other DentSim sources); output 1: a
// table with one row per tissue: Tissue, RemovedVolume, VolumeBefore, VolumeAfter (mm^3).
#pragma once

#include <vtkMultiBlockDataSetAlgorithm.h>

#include "DentSimSourcesModule.h"

class DENTSIMSOURCES_EXPORT vtkDentSimPreparation : public vtkMultiBlockDataSetAlgorithm {
public:
  static vtkDentSimPreparation* New();
  vtkTypeMacro(vtkDentSimPreparation, vtkMultiBlockDataSetAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  vtkSetStringMacro(TissuesFile);
  vtkGetStringMacro(TissuesFile);
  vtkSetMacro(TissueVoxelSize, double);
  vtkGetMacro(TissueVoxelSize, double);
  vtkSetMacro(PhantomVoxelSize, double);
  vtkGetMacro(PhantomVoxelSize, double);
  vtkSetStringMacro(ToolPathFile);
  vtkGetStringMacro(ToolPathFile);
  vtkSetStringMacro(Burr);
  vtkGetStringMacro(Burr);
  vtkSetMacro(Force, double);
  vtkGetMacro(Force, double);

protected:
  vtkDentSimPreparation();
  ~vtkDentSimPreparation() override;
  int FillInputPortInformation(int port, vtkInformation* info) override;
  int FillOutputPortInformation(int port, vtkInformation* info) override;
  int RequestDataObject(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  char* TissuesFile = nullptr;
  double TissueVoxelSize = 0.05;
  double PhantomVoxelSize = 0.05;
  char* ToolPathFile = nullptr;
  char* Burr = nullptr;
  double Force = 0.0;

private:
  vtkDentSimPreparation(const vtkDentSimPreparation&) = delete;
  void operator=(const vtkDentSimPreparation&) = delete;
};
