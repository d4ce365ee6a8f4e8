// Reads a dentsim tissues .vdb (one level-set grid per tissue, named by the tissue) into a
// multiblock of tissue surfaces, one block per tissue with its properties as field data.
#pragma once

#include <vtkMultiBlockDataSetAlgorithm.h>

#include "DentSimSourcesModule.h"

class DENTSIMSOURCES_EXPORT vtkDentSimTissueReader : public vtkMultiBlockDataSetAlgorithm {
public:
  static vtkDentSimTissueReader* New();
  vtkTypeMacro(vtkDentSimTissueReader, vtkMultiBlockDataSetAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  vtkSetStringMacro(FileName);
  vtkGetStringMacro(FileName);

  // ParaView's reader factory asks this before offering the reader for a file.
  int CanReadFile(const char* fileName);

protected:
  vtkDentSimTissueReader();
  ~vtkDentSimTissueReader() override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  char* FileName = nullptr;

private:
  vtkDentSimTissueReader(const vtkDentSimTissueReader&) = delete;
  void operator=(const vtkDentSimTissueReader&) = delete;
};
