// "Dental Preparation Assessment": grades a preparation in the Rust core (dentsim assess).
// The prepared tissues, the original they were cut from and, optionally, a reference preparation
// each come from an input (ports 1–3: tissue surfaces upstream, one block per tissue, rebuilt as
// level sets at TissueVoxelSize) or else from a file (.vdb, or an output folder holding
// tissues.vdb). Port 0 stays unconnected, so ParaView never binds the active source to it. Output 0: the
// prepared tooth's outer surface with point arrays DeviationMm (signed distance from the
// reference's surface, + where deeper; 0 without a reference) and CutDepthMm (below the original
// surface); output 1: a table of every figure and grade (Criterion, Value, Unit, Range, Verdict,
// Source). With Kind = crown, the crown's taper, reductions, margin and undercut along the path
// of insertion (Axis, or the tooth's long axis when UseAxis is off).
#pragma once

#include <vtkPolyDataAlgorithm.h>

#include "DentSimSourcesModule.h"

class DENTSIMSOURCES_EXPORT vtkDentSimPreparationAssessment : public vtkPolyDataAlgorithm {
public:
  static vtkDentSimPreparationAssessment* New();
  vtkTypeMacro(vtkDentSimPreparationAssessment, vtkPolyDataAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  vtkSetStringMacro(PreparedFile);
  vtkGetStringMacro(PreparedFile);
  vtkSetStringMacro(OriginalFile);
  vtkGetStringMacro(OriginalFile);
  vtkSetStringMacro(ReferenceFile);
  vtkGetStringMacro(ReferenceFile);
  // 0: cavity, 1: crown.
  vtkSetClampMacro(Kind, int, 0, 1);
  vtkGetMacro(Kind, int);
  vtkSetMacro(UseAxis, bool);
  vtkGetMacro(UseAxis, bool);
  vtkSetVector3Macro(Axis, double);
  vtkGetVector3Macro(Axis, double);
  vtkSetMacro(TissueVoxelSize, double);
  vtkGetMacro(TissueVoxelSize, double);

protected:
  vtkDentSimPreparationAssessment();
  ~vtkDentSimPreparationAssessment() override;
  int FillInputPortInformation(int port, vtkInformation* info) override;
  int FillOutputPortInformation(int port, vtkInformation* info) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  char* PreparedFile = nullptr;
  char* OriginalFile = nullptr;
  char* ReferenceFile = nullptr;
  int Kind = 0;
  bool UseAxis = false;
  double Axis[3] = {0.0, 0.0, 1.0};
  double TissueVoxelSize = 0.05;

private:
  vtkDentSimPreparationAssessment(const vtkDentSimPreparationAssessment&) = delete;
  void operator=(const vtkDentSimPreparationAssessment&) = delete;
};
