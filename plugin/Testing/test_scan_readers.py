"""One scan opened with each of ParaView's own readers (DICOM, NIfTI, MetaImage) gives the tissues
`dentsim segment` gives from the same file, in the same (patient LPS) frame. The DICOM series is
written by pydicom as scanners store it (signed 16-bit, a series position, LPS axes), the NIfTI by
nibabel, both from the phantom; the MetaImage by dentsim. Also: the Grey Values array selector,
and All Teeth (one block per tooth)."""
import json
import os
import subprocess

import nibabel
import numpy
import pydicom
from pydicom.dataset import FileDataset, FileMetaDataset
from pydicom.uid import ExplicitVRLittleEndian, generate_uid
from paraview import servermanager, simple

from test_inputs import phantom_scan
from dentsim_testing import check, parse_args

args = parse_args()
simple.LoadPlugin(args.plugin, ns=globals())
temp = os.path.join(args.temp, "scan_readers")
os.makedirs(temp, exist_ok=True)

seed = phantom_scan(args.dentsim, os.path.join(temp, "phantom.nii.gz"), fmt="nifti")
phantom = nibabel.load(os.path.join(temp, "phantom.nii.gz"))
grey = numpy.asarray(phantom.dataobj, dtype=numpy.float64)
affine = phantom.affine  # voxel -> RAS mm

# nibabel's NIfTI: signed 16-bit, the phantom's grey values shifted below zero (as HU-like
# scanners store them), the same affine.
peer_nifti = os.path.join(temp, "peer.nii")
stored = numpy.round(grey - 1500.0).astype(numpy.int16)
nibabel.save(nibabel.Nifti1Image(stored, affine), peer_nifti)

# pydicom's series: the same signed values, one file per slice, positions in LPS.
lps = numpy.diag([-1.0, -1.0, 1.0]) @ affine[:3, :]


def write_series(series, stored, lps):
    os.makedirs(series, exist_ok=True)
    spacing = [float(numpy.linalg.norm(lps[:, c])) for c in range(3)]
    row_dir = lps[:, 0] / spacing[0]
    col_dir = lps[:, 1] / spacing[1]
    study, series_uid = generate_uid(), generate_uid()
    for k in range(stored.shape[2]):
        write_slice(series, stored, lps, spacing, row_dir, col_dir, study, series_uid, k)


def write_slice(series, stored, lps, spacing, row_dir, col_dir, study, series_uid, k):
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.2"
    meta.MediaStorageSOPInstanceUID = generate_uid()
    meta.TransferSyntaxUID = ExplicitVRLittleEndian
    path = os.path.join(series, "slice%04d.dcm" % k)
    ds = FileDataset(path, {}, file_meta=meta, preamble=b"\0" * 128)
    ds.SOPClassUID = meta.MediaStorageSOPClassUID
    ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
    ds.StudyInstanceUID, ds.SeriesInstanceUID = study, series_uid
    ds.Modality = "CT"
    ds.InstanceNumber = k + 1
    ds.ImagePositionPatient = [float(v) for v in lps[:, 3] + lps[:, 2] * k]
    ds.ImageOrientationPatient = [float(v) for v in list(row_dir) + list(col_dir)]
    ds.PixelSpacing = [spacing[1], spacing[0]]  # row spacing (between rows), column spacing
    ds.SliceThickness = spacing[2]
    ds.Rows, ds.Columns = stored.shape[1], stored.shape[0]
    ds.SamplesPerPixel = 1
    ds.PhotometricInterpretation = "MONOCHROME2"
    ds.BitsAllocated, ds.BitsStored, ds.HighBit = 16, 16, 15
    ds.PixelRepresentation = 1
    ds.RescaleIntercept, ds.RescaleSlope = 0, 1
    ds.PixelData = numpy.ascontiguousarray(stored[:, :, k].T).tobytes()
    ds.is_little_endian, ds.is_implicit_VR = True, False
    ds.save_as(path, write_like_original=False)


series = os.path.join(temp, "series")
write_series(series, stored, lps)
# The same scan stored mirrored along the rows and columns (the index axes run the other way,
# the series' position is the far corner): where a reader keeps the patient frame, the tooth
# stays where it was.
flipped = os.path.join(temp, "series_flipped")
turned = numpy.ascontiguousarray(stored[::-1, ::-1, :])
far = lps[:, 3] + lps[:, 0] * (stored.shape[0] - 1) + lps[:, 1] * (stored.shape[1] - 1)
write_series(flipped, turned, numpy.column_stack([-lps[:, 0], -lps[:, 1], lps[:, 2], far]))

mha = os.path.join(temp, "scan.mha")
phantom_scan(args.dentsim, mha)


# The readers' frames and grey values are what is compared, not the tissues' accuracy: a coarser
# tissue grid than the default 0.05 mm, the same for both, keeps the 13 segmentations quick.
VOXEL_MM = 0.1


def cli(path, name):
    """`dentsim segment` on the file: its report's volumes and its tissues' bounds."""
    out = os.path.join(temp, name + ".vdb")
    subprocess.run([args.dentsim, "segment", path, "--out", out, "--voxel", str(VOXEL_MM), "--point", ",".join(str(v) for v in seed)],
                   check=True, capture_output=True, text=True)
    report = json.load(open(out + ".json"))
    tissues = servermanager.Fetch(simple.OpenDataFile(out))
    bounds = {tissues.GetMetaData(i).Get(tissues.NAME()): tissues.GetBlock(i).GetBounds()
              for i in range(tissues.GetNumberOfBlocks())}
    return {t["name"]: t["volume_mm3"] for t in report["tissues"]}, bounds


def paraview(reader, **properties):
    tissues = DentalTissuesFromScan(Input=reader)
    tissues.UseSeedPoint = 1
    tissues.SeedPointmm = seed
    tissues.VoxelSizemm = VOXEL_MM
    for key, value in properties.items():
        setattr(tissues, key, value)
    tissues.UpdatePipeline()
    data = servermanager.Fetch(tissues)
    names = [data.GetMetaData(i).Get(data.NAME()) for i in range(data.GetNumberOfBlocks())]
    volumes = {n: data.GetBlock(i).GetFieldData().GetArray("VolumeBefore").GetValue(0) for i, n in enumerate(names)}
    bounds = {n: data.GetBlock(i).GetBounds() for i, n in enumerate(names)}
    source = data.GetBlock(0).GetFieldData().GetAbstractArray("ScanSource").GetValue(0) if names else ""
    # The phantom's pulp is whole: nothing doubtful to say about any tissue.
    for i, n in enumerate(names):
        check(data.GetBlock(i).GetFieldData().GetAbstractArray("Warnings") is None, "%s: no warnings on the phantom" % n)
    return volumes, bounds, source


def same(what, ours, theirs):
    (v1, b1), (v2, b2) = ours, theirs
    check(sorted(v1) == sorted(v2) == ["dentin", "enamel", "pulp"], "%s: tissues %s vs %s" % (what, sorted(v1), sorted(v2)))
    for name in v1:
        check(abs(v1[name] / v2[name] - 1.0) < 1e-3, "%s %s volume %.3f vs the CLI's %.3f" % (what, name, v1[name], v2[name]))
        far = max(abs(a - b) for a, b in zip(b1[name], b2[name]))
        # A wrong frame (origin, axis flip, signedness) moves a tissue by a scan voxel (0.2 mm) or
        # more; a series stored mirrored is resampled onto the tissues' grid from the other side,
        # which moves a thin edge by a fraction of that grid's voxel (0.0145 mm at 0.1 mm).
        check(far < 0.2 * VOXEL_MM, "%s %s bounds %s vs the CLI's %s" % (what, name, b1[name], b2[name]))
        print("%s %s %.2f mm3, bounds within %.4f mm of the CLI's" % (what, name, v1[name], far))


readers = [
    ("DICOM", series, lambda: simple.DICOMReaderdirectory(FileName=series)),
    ("DICOM mirrored", flipped, lambda: simple.DICOMReaderdirectory(FileName=flipped)),
    ("NIfTI", peer_nifti, lambda: simple.OpenDataFile(peer_nifti)),
    ("MetaImage", mha, lambda: simple.OpenDataFile(mha)),
]
# ParaView reads NIfTI through this plugin, shipped with it
simple.LoadPlugin("/usr/lib/x86_64-linux-gnu/paraview-5.11/plugins/AnalyzeNIfTIReaderWriter/AnalyzeNIfTIReaderWriter.so",
                  remote=False, ns=globals())
for what, path, open_reader in readers:
    reader = open_reader()
    check(reader is not None, "ParaView opens the %s file" % what)
    volumes, bounds, source = paraview(reader)
    check("dentsim's reader" in source and path in source, "%s: ScanSource says what was read: %s" % (what, source))
    same(what, (volumes, bounds), cli(path, what.replace(" ", "_")))
    if what == "DICOM mirrored":
        # the same tissues, in the same place, as from the series stored the usual way
        same(what + " vs DICOM", (volumes, bounds), cli(series, "DICOM"))

# The Grey Values selector: a second array (the grey values scaled and shifted, which calibration
# reads alike) is segmented as chosen; a ramp chosen instead is refused.
reader = simple.OpenDataFile(mha)
scaled = simple.Calculator(Input=reader, ResultArrayName="Scaled", Function="2*MetaImage-300")
ramp = simple.Calculator(Input=scaled, ResultArrayName="Ramp", Function="coordsX")
volumes, bounds, source = paraview(ramp, GreyValues=["POINTS", "Scaled"])
check(source == "input array 'Scaled' in the image's frame", "the chosen array was read: %s" % source)
same("array Scaled", (volumes, bounds), cli(mha, "MetaImage"))
volumes, _, _ = paraview(ramp, GreyValues=["POINTS", "Ramp"])
check(volumes == {}, "a ramp gives no tissues: %s" % volumes)
# All Teeth: one block per tooth, each holding its tissues; the largest is the molar at the seed.
tissues = DentalTissuesFromScan(Input=simple.OpenDataFile(mha))
tissues.AllTeeth = 1
tissues.VoxelSizemm = VOXEL_MM
tissues.UpdatePipeline()
data = servermanager.Fetch(tissues)
names = [data.GetMetaData(i).Get(data.NAME()) for i in range(data.GetNumberOfBlocks())]
print("All Teeth blocks: %s" % names)
check(len(names) == 3 and names[0] == "tooth 1" and all(n.startswith("tooth ") for n in names),
      "three teeth, one block each: %s" % names)
first = data.GetBlock(0)
volumes = {first.GetMetaData(i).Get(first.NAME()): first.GetBlock(i).GetFieldData().GetArray("VolumeBefore").GetValue(0)
           for i in range(first.GetNumberOfBlocks())}
bounds = {first.GetMetaData(i).Get(first.NAME()): first.GetBlock(i).GetBounds() for i in range(first.GetNumberOfBlocks())}
same("All Teeth, tooth 1", (volumes, bounds), cli(mha, "MetaImage"))


def warnings_both_ways(case, keep_shading=False):
    """foreign_tooth.py's `case` segmented by `dentsim segment` and, through ParaView's NIfTI
    reader, by Dental Tissues From Scan (`keep_shading`: `--keep-shading` and Keep Shading): the
    CLI report's warnings, and ParaView's blocks by name with each block's `Warnings` (empty
    where it has none)."""
    made = json.loads(subprocess.run(["/usr/bin/python3" if os.path.exists("/usr/bin/python3") else "python3",
                                      os.path.join(os.path.dirname(os.path.abspath(__file__)), "../../crates/cli/tests/foreign/foreign_tooth.py"),
                                      os.path.join(temp, case), case], check=True, capture_output=True, text=True).stdout)
    out = os.path.join(temp, case + ".vdb")
    subprocess.run([args.dentsim, "segment", made["path"], "--out", out, "--voxel", str(VOXEL_MM), "--point", ",".join(str(v) for v in made["inside"])]
                   + (["--keep-shading"] if keep_shading else []), check=True, capture_output=True, text=True)
    said = json.load(open(out + ".json"))["warnings"]
    nii = os.path.join(temp, case + ".nii")  # ParaView's NIfTI reader does not read .nii.gz
    nibabel.save(nibabel.load(made["path"]), nii)
    tissues = DentalTissuesFromScan(Input=simple.OpenDataFile(nii))
    tissues.UseSeedPoint = 1
    tissues.SeedPointmm = made["inside"]
    tissues.VoxelSizemm = VOXEL_MM
    tissues.KeepShading = int(keep_shading)
    tissues.UpdatePipeline()
    data = servermanager.Fetch(tissues)
    shown = {}
    for i in range(data.GetNumberOfBlocks()):
        array = data.GetBlock(i).GetFieldData().GetAbstractArray("Warnings")
        shown[data.GetMetaData(i).Get(data.NAME())] = [array.GetValue(k) for k in range(array.GetNumberOfValues())] if array else []
    print("%s: the CLI's warnings %s; ParaView's by block %s" % (case, said, shown))
    return said, shown


# A scan another tool wrote whose pulp dentsim cannot fully resolve (an incisor in bone at 0.4 mm:
# its 0.8 mm canal two voxels wide, its volume resting on the fit through the blur): through
# ParaView's NIfTI reader, the pulp's block carries the report's warnings, word for word as
# `dentsim segment` gives them.
said, shown = warnings_both_ways("incisor_jaw")
check(any("fitted through the scan's blur" in w and "does not resolve" in w for w in said), "the CLI says the pulp's volume is uncertain: %s" % said)
check(sorted(shown) == ["dentin", "enamel", "pulp"], "incisor tissues: %s" % sorted(shown))
check(shown["pulp"] == said, "the pulp's Warnings %s vs the CLI's %s" % (shown["pulp"], said))
check(shown["enamel"] == [] and shown["dentin"] == [], "warnings only on the pulp")

# A filling the scanner clipped (foreign_tooth.py's clipped_filling: 40000 HU stored as int16):
# the enamel and dentin beside it are in doubt, and the warning saying so is on the enamel's block.
said, shown = warnings_both_ways("clipped_filling")
check(any(w.startswith("a metal restoration saturates the scan") for w in said), "the CLI says the filling is clipped: %s" % said)
check(shown["enamel"] == said, "the enamel's Warnings %s vs the CLI's %s" % (shown["enamel"], said))
check(shown["dentin"] == [] and shown["pulp"] == [], "the clipped filling's warning only on the enamel")

# A cone-beam scanner's shading (foreign_tooth.py's shaded_jaw: 300 HU of cupping and ramp): read
# through ParaView's NIfTI reader it is taken off as by the CLI, and the warning saying how far it
# ran over the tooth is on the dentin's block, word for word.
said, shown = warnings_both_ways("shaded_jaw")
check(any(w.startswith("the scan's grey values drift by") for w in said), "the CLI says the shading was taken off: %s" % said)
check(shown["dentin"] == said, "the dentin's Warnings %s vs the CLI's %s" % (shown["dentin"], said))
check(shown["enamel"] == [] and shown["pulp"] == [], "the shading's warning only on the dentin")
# Keep Shading: the same drift measured and said, left on as asked, by both alike.
kept_said, kept_shown = warnings_both_ways("shaded_jaw", keep_shading=True)
kept = [w for w in kept_said if w.startswith("the scan's grey values drift by")]
check(len(kept) == 1 and "left on as asked" in kept[0], "the CLI says the shading was left on: %s" % kept_said)
check(kept[0].split(" over the tooth")[0] in [w.split(" over the tooth")[0] for w in said], "the drift measured as when taken off: %s vs %s" % (kept[0], said))
check(kept_shown["dentin"] == kept_said, "the dentin's Warnings %s vs the CLI's %s" % (kept_shown["dentin"], kept_said))
print("PASSED test_scan_readers")
