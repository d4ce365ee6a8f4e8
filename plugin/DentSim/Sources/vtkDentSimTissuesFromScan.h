// One tooth's tissue surfaces from a CBCT image (any vtkImageData with one scalar component,
// e.g. from ParaView's DICOM, NIfTI or MetaImage readers): grey values are calibrated per scan,
// the tooth is segmented and each tissue becomes a smooth level set at VoxelSize (mm). Output:
// one block per tissue, named after it. When the image comes straight from a reader of a scan
// file (ParaView's DICOM, NIfTI or MetaImage reader), the file is read again through dentsim's
// own reader, which keeps the patient frame (DICOM's signed pixels, origin and LPS axes; the
// NIfTI and MetaImage orientation) that those readers drop: the tissues land where
// `dentsim segment` puts them, and each block's ScanSource field says which was read. Otherwise
// the grey values are the selected point array of the image, in the image's world frame.
// With AllTeeth, every tooth in the scan is its own block ("tooth N", N by size), holding its
// tissue blocks.
#pragma once

#include <vtkMultiBlockDataSetAlgorithm.h>

#include "DentSimSourcesModule.h"

class DENTSIMSOURCES_EXPORT vtkDentSimTissuesFromScan : public vtkMultiBlockDataSetAlgorithm {
public:
  static vtkDentSimTissuesFromScan* New();
  vtkTypeMacro(vtkDentSimTissuesFromScan, vtkMultiBlockDataSetAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  vtkSetMacro(VoxelSize, double);
  vtkGetMacro(VoxelSize, double);
  vtkSetMacro(Tooth, int);
  vtkGetMacro(Tooth, int);
  vtkSetMacro(UseSeedPoint, bool);
  vtkGetMacro(UseSeedPoint, bool);
  vtkSetVector3Macro(SeedPoint, double);
  vtkGetVector3Macro(SeedPoint, double);
  vtkSetMacro(ReadScanFile, bool);
  vtkGetMacro(ReadScanFile, bool);
  vtkSetMacro(AllTeeth, bool);
  vtkGetMacro(AllTeeth, bool);
  vtkSetStringMacro(Thresholds);
  vtkGetStringMacro(Thresholds);
  vtkSetMacro(KeepShading, bool);
  vtkGetMacro(KeepShading, bool);

protected:
  vtkDentSimTissuesFromScan();
  ~vtkDentSimTissuesFromScan() override;
  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  double VoxelSize = 0.05;
  int Tooth = 36;
  bool UseSeedPoint = false;
  double SeedPoint[3] = {0.0, 0.0, 0.0};
  bool ReadScanFile = true;
  bool AllTeeth = false;
  char* Thresholds = nullptr;
  bool KeepShading = false;

private:
  vtkDentSimTissuesFromScan(const vtkDentSimTissuesFromScan&) = delete;
  void operator=(const vtkDentSimTissuesFromScan&) = delete;
};
