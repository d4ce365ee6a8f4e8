// The capsule phantom (enamel over dentin over pulp) cut by one straight stroke of a round burr,
// as a multiblock of tissue surfaces. All lengths in mm, in the phantom's (LPS) frame.
#pragma once

#include <vtkMultiBlockDataSetAlgorithm.h>

#include "DentSimSourcesModule.h"

class DENTSIMSOURCES_EXPORT vtkDentSimPhantomStroke : public vtkMultiBlockDataSetAlgorithm {
public:
  static vtkDentSimPhantomStroke* New();
  vtkTypeMacro(vtkDentSimPhantomStroke, vtkMultiBlockDataSetAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  vtkSetMacro(VoxelSize, double);
  vtkGetMacro(VoxelSize, double);
  vtkSetMacro(BurrDiameter, double);
  vtkGetMacro(BurrDiameter, double);
  vtkSetVector3Macro(StrokeStart, double);
  vtkGetVector3Macro(StrokeStart, double);
  vtkSetVector3Macro(StrokeEnd, double);
  vtkGetVector3Macro(StrokeEnd, double);

protected:
  vtkDentSimPhantomStroke();
  ~vtkDentSimPhantomStroke() override = default;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  double VoxelSize;
  double BurrDiameter;
  double StrokeStart[3];
  double StrokeEnd[3];

private:
  vtkDentSimPhantomStroke(const vtkDentSimPhantomStroke&) = delete;
  void operator=(const vtkDentSimPhantomStroke&) = delete;
};
