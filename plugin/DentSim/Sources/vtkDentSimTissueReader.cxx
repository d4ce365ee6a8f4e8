#include "vtkDentSimTissueReader.h"

#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkMultiBlockDataSet.h>
#include <vtkObjectFactory.h>

#include <fstream>

#include "vtkDentSimSurfaces.h"

vtkStandardNewMacro(vtkDentSimTissueReader);

vtkDentSimTissueReader::vtkDentSimTissueReader() { this->SetNumberOfInputPorts(0); }

vtkDentSimTissueReader::~vtkDentSimTissueReader() { this->SetFileName(nullptr); }

int vtkDentSimTissueReader::CanReadFile(const char* fileName) {
  // OpenVDB files start with the magic number 0x56444220 ("VDB "), little endian.
  std::ifstream in(fileName, std::ios::binary);
  unsigned char magic[4] = {0, 0, 0, 0};
  in.read(reinterpret_cast<char*>(magic), 4);
  return in && magic[0] == 0x20 && magic[1] == 0x42 && magic[2] == 0x44 && magic[3] == 0x56;
}

int vtkDentSimTissueReader::RequestData(vtkInformation*, vtkInformationVector**,
                                        vtkInformationVector* outputVector) {
  vtkMultiBlockDataSet::GetData(outputVector, 0)->Initialize();
  if (!dentsim::IsPieceZero(outputVector)) return 1;
  if (!this->FileName || !*this->FileName) {
    vtkErrorMacro(<< "DentSim: no file name given");
    return 0;
  }
  try {
    dentsim::FillTissueBlocks(dentsim::ffi::read_tissues(this->FileName),
                              vtkMultiBlockDataSet::GetData(outputVector, 0));
  } catch (const rust::Error& e) {
    vtkErrorMacro(<< "DentSim: " << e.what());
    return 0;
  }
  return 1;
}

void vtkDentSimTissueReader::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "FileName: " << (this->FileName ? this->FileName : "(none)") << "\n";
}
