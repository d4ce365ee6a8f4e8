// "Dental Batch Plan": plans a cohort (a manifest of scans × preparations, as `dentsim batch`)
// with ParaView's own parallelism: under `mpiexec -n N pvbatch` each rank is asked for piece I
// of N and runs that shard of the cases; Step 1 (Merge) then writes the one report on the rank
// asked for piece 0. Output: a table with one row per case and tissue of the cases this rank
// ran (or, merging, of every case): Case, Scan, Preparation, Burr, Tissue, RemovedVolume,
// VolumeBefore, VolumeAfter (mm^3), Seconds.
#pragma once

#include <vtkTableAlgorithm.h>

#include "DentSimSourcesModule.h"

class DENTSIMSOURCES_EXPORT vtkDentSimBatchPlan : public vtkTableAlgorithm {
public:
  static vtkDentSimBatchPlan* New();
  vtkTypeMacro(vtkDentSimBatchPlan, vtkTableAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  vtkSetStringMacro(ManifestFile);
  vtkGetStringMacro(ManifestFile);
  vtkSetStringMacro(OutputDirectory);
  vtkGetStringMacro(OutputDirectory);
  // 0: run this rank's share of the cases; 1: merge every case's figures into the report.
  vtkSetClampMacro(Step, int, 0, 1);
  vtkGetMacro(Step, int);

protected:
  vtkDentSimBatchPlan();
  ~vtkDentSimBatchPlan() override;
  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  char* ManifestFile = nullptr;
  char* OutputDirectory = nullptr;
  int Step = 0;

private:
  vtkDentSimBatchPlan(const vtkDentSimBatchPlan&) = delete;
  void operator=(const vtkDentSimBatchPlan&) = delete;
};
