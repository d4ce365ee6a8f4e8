"""A tooth dentsim has never seen, made the way another group would make a test scan: numpy shapes
(a superellipsoid crown with its enamel cap, a conical root, a pulp chamber with its canal), grey
values in the scanner's own units, partial volume, blur and noise, written by nibabel (NIfTI) or
pydicom (a DICOM series). Nothing here comes from dentsim's phantom.

    python3 foreign_tooth.py OUT CASE

CASE: jaw (in bone and soft tissue, tilted 15 degrees, NIfTI; its root fused to the bone), socket
(the same with a 0.3 mm ligament between the root and its socket), air (an extracted tooth on a wax
block, in air, DICOM series, grey values signed and offset), water (in water, anisotropic
voxels, NIfTI), incisor (an extracted incisor in air, its canal 0.4 mm from the root's side
near the apex, DICOM series stored unsigned with a rescale slope and intercept), or water12 (the
water case from a 12-bit CBCT, DICOM series, 0.3 mm voxels, its enamel–dentin contrast below the
typical tissues' against the dentin's over water), or scaled (a molar in air, its pulp soft tissue,
0.25 mm voxels, NIfTI int16 with scl_slope 2 and scl_inter -1000), or fine (a molar in air, its pulp
soft tissue, 0.1 mm voxels, the blur two voxels wide, NIfTI float), or incisor_jaw (the incisor in
bone and soft tissue, 0.4 mm voxels, its pulp 300 HU, NIfTI int16), or incisor_coarse (the extracted
incisor in air at 0.4 mm, its pulp 300 HU, NIfTI float: its canal two voxels wide), or
incisor_jaw_wide (the incisor in bone, soft tissue and air over a wider field of view at 0.25 mm,
its pulp 40 HU, NIfTI int16: the jaw's blurred edges make more histogram bumps than the enamel), or
incisor_jaw_fine (the same at 0.1 mm: the point spread two voxels wide, its crown above the gum in
air), or custom (the sweep's: SHAPE molar|incisor, MEDIUM air|water|jaw, VOXEL mm, PULP HU, SEED
and FILLING (an occlusal metal filling's HU, none if empty) from the environment, HU as stored,
NIfTI int16; see sweep.py), or filled_jaw (custom's molar in a jaw at 0.3 mm, a 12000 HU filling), or filled_incisor (custom's
incisor in a jaw at 0.25 mm, the same filling), or filled_incisor_air (the same incisor in air), or clipped_filling (a molar in air at 0.2 mm
whose 40000 HU filling the int16 storage clips at 32767, as a saturating scanner would), or clipped_jaw (the same filling
clipped, in a molar in a jaw at 0.2 mm), or gold_incisor (an unclipped 30000 HU filling, gold's range, in an incisor in air
at 0.3 mm, its pulp 300 HU, int16 as the sweep's; stored as float32 the same scan was not refused), or incisor_water_fine
(custom's incisor in water at 0.1 mm, the point spread two voxels wide, int16 as the sweep's), or shaded_jaw / shaded_incisor_water
(custom's molar in a jaw at 0.3 mm / incisor in water at 0.25 mm under a cone-beam shading of 300 HU: SHADING, also custom's,
a cupping toward the field's axis and a ramp along it; the JSON then gives its span over the tooth, 5th to 95th percentile), or
humped_incisor_jaw (custom's incisor in a jaw at 0.25 mm under a 400 HU Gaussian hump of scatter, SHADING_FORM=bump), or
streaked_incisor_jaw (custom's incisor in a jaw at 0.35 mm, its 12000 HU filling hardening the beam: STREAKS 0.5, also custom's,
each axial ray's attenuation through the metal read short by 0.5 times its square, reconstructed by filtered back-projection). Prints one JSON line: the file written, a point inside the tooth (LPS mm) and the
true volume of each tissue (mm^3).
"""
import json
import math
import os
import sys

import numpy as np

OUT, CASE = sys.argv[1], sys.argv[2]
CUSTOM = CASE in ("custom", "streaked_incisor_jaw", "shaded_jaw", "shaded_incisor_water", "humped_incisor_jaw", "filled_jaw", "filled_incisor", "filled_incisor_air", "clipped_filling", "clipped_jaw", "gold_incisor", "incisor_water_fine")
SHADING, SHADING_FORM, STREAKS = 0.0, "cupping", 0.0
if CASE == "shaded_jaw":  # the sweep's molar in a jaw at 0.3 mm under a cone-beam scanner's shading
    SHAPE, MEDIUM, VOXEL, PULP_HU, SEED, FILLING, SHADING = "molar", "jaw", 0.3, 40.0, 5, "", 300.0
elif CASE == "shaded_incisor_water":  # its incisor in water at 0.25 mm under the same shading
    SHAPE, MEDIUM, VOXEL, PULP_HU, SEED, FILLING, SHADING = "incisor", "water", 0.25, 40.0, 5, "", 300.0
elif CASE == "humped_incisor_jaw":  # the sweep's incisor_jaw_0.25_40 (its seed) under a 400 HU hump of scatter
    SHAPE, MEDIUM, VOXEL, PULP_HU, SEED, FILLING, SHADING, SHADING_FORM = "incisor", "jaw", 0.25, 40.0, 191, "", 400.0, "bump"
elif CASE == "streaked_incisor_jaw":  # the sweep's incisor_jaw_0.35_40 (its seed), its filling hardening the beam
    SHAPE, MEDIUM, VOXEL, PULP_HU, SEED, FILLING, STREAKS = "incisor", "jaw", 0.35, 40.0, 303, "12000", 0.5
elif CASE == "filled_jaw":  # the sweep's molar in a jaw at 0.3 mm with an amalgam filling
    SHAPE, MEDIUM, VOXEL, PULP_HU, SEED, FILLING = "molar", "jaw", 0.3, 40.0, 22, "12000"
elif CASE == "filled_incisor":  # the sweep's incisor in a jaw at 0.25 mm with one
    SHAPE, MEDIUM, VOXEL, PULP_HU, SEED, FILLING = "incisor", "jaw", 0.25, 40.0, 23, "12000"
elif CASE == "filled_incisor_air":  # the sweep's incisor_air_0.25_40 with one (the sweep's seed)
    SHAPE, MEDIUM, VOXEL, PULP_HU, SEED, FILLING = "incisor", "air", 0.25, 40.0, 152, "12000"
elif CASE == "clipped_filling":  # the sweep's molar_air_0.2_40, its filling clipped at int16's top
    SHAPE, MEDIUM, VOXEL, PULP_HU, SEED, FILLING = "molar", "air", 0.2, 40.0, 805, "40000"
elif CASE == "clipped_jaw":  # the same clipped filling in the sweep's molar_jaw_0.2_40 (its seed)
    SHAPE, MEDIUM, VOXEL, PULP_HU, SEED, FILLING = "molar", "jaw", 0.2, 40.0, 805, "40000"
elif CASE == "gold_incisor":  # the sweep's incisor_air_0.3_300 (its seed) with a gold filling
    SHAPE, MEDIUM, VOXEL, PULP_HU, SEED, FILLING = "incisor", "air", 0.3, 300.0, 823, "30000"
elif CASE == "incisor_water_fine":  # the sweep's incisor_water_0.1_40 (its seed)
    SHAPE, MEDIUM, VOXEL, PULP_HU, SEED, FILLING = "incisor", "water", 0.1, 40.0, 701, ""
elif CUSTOM:
    SHAPE, MEDIUM = os.environ.get("SHAPE", "molar"), os.environ.get("MEDIUM", "air")
    VOXEL, PULP_HU, SEED = float(os.environ.get("VOXEL", "0.3")), float(os.environ.get("PULP", "40")), int(os.environ.get("SEED", "1"))
    FILLING = os.environ.get("FILLING", "")  # "" none, or the filling's grey (HU; e.g. 12000 amalgam)
    # A cone-beam scanner's shading (HU): cupping, darker toward the axis of rotation, and a
    # ramp along it from the cone's angle. None unless asked for.
    SHADING = float(os.environ.get("SHADING", "0"))
    # "bump": instead a scatter-like Gaussian hump of that height off the field's middle (no
    # quadratic, which dentsim's correction fits)
    SHADING_FORM = os.environ.get("SHADING_FORM", "cupping")
    # The filling's beam hardening (none if 0): each axial slice's rays through the metal read
    # their attenuation p short by STREAKS * p^2 (0.1-0.3 taken as a metal's), reconstructed by
    # filtered back-projection: dark streaks along the metal's long chords, bright ones beside.
    STREAKS = float(os.environ.get("STREAKS", "0"))
INCISOR = CASE in ("incisor", "incisor_jaw", "incisor_coarse", "incisor_jaw_wide", "incisor_jaw_fine") or (CUSTOM and SHAPE == "incisor")
rng = np.random.default_rng(SEED if CUSTOM else {"jaw": 11, "air": 12, "water": 13, "socket": 14, "incisor": 15, "water12": 16, "scaled": 17, "fine": 18, "incisor_jaw": 19, "incisor_coarse": 20, "incisor_jaw_wide": 191, "incisor_jaw_fine": 21}[CASE])
JAW = CASE in ("jaw", "socket", "incisor_jaw", "incisor_jaw_wide", "incisor_jaw_fine") or (CUSTOM and MEDIUM == "jaw")

# Grid in the tooth's own frame (mm): z along the tooth, occlusal up; fine grid for the truth and
# the partial volume, averaged into the scan's voxels.
spacing = (VOXEL,) * 3 if CUSTOM else {"jaw": (0.2, 0.2, 0.2), "socket": (0.2, 0.2, 0.2), "air": (0.25, 0.25, 0.25), "water": (0.15, 0.15, 0.3), "incisor": (0.2, 0.2, 0.2), "water12": (0.3, 0.3, 0.3), "scaled": (0.25, 0.25, 0.25), "fine": (0.1, 0.1, 0.1), "incisor_jaw": (0.4, 0.4, 0.4), "incisor_coarse": (0.4, 0.4, 0.4), "incisor_jaw_wide": (0.25, 0.25, 0.25), "incisor_jaw_fine": (0.1, 0.1, 0.1)}[CASE]
FINE = 2 if CASE in ("fine", "incisor_jaw_fine") or (CUSTOM and VOXEL <= 0.15) else 3  # sub-samples per voxel and axis
extent = ((-7.0, 7.0), (-7.0, 7.0), (-16.0, 12.0 if INCISOR else 10.0))  # the incisor's crown is 10 mm tall
if CASE == "incisor_jaw":  # a field of view filled by the jaw's bone
    extent = ((-6.0, 6.0), (-5.5, 5.5), (-15.0, 12.0))
dims = [int(round((hi - lo) / s)) for (lo, hi), s in zip(extent, spacing)]


def fine_axis(axis):
    lo, s = extent[axis][0], spacing[axis]
    return lo + (np.arange(dims[axis] * FINE) + 0.5) * s / FINE


x, y, z = np.meshgrid(fine_axis(0), fine_axis(1), fine_axis(2), indexing="ij", sparse=True)


def superellipsoid(cx, cy, cz, a, b, c, p):
    return np.abs((x - cx) / a) ** p + np.abs((y - cy) / b) ** p + np.abs((z - cz) / c) ** p <= 1.0


radius = lambda top, bottom: top + (bottom - top) * np.clip(-z / 13.0, 0.0, 1.0)  # noqa: E731
if INCISOR:
    # A chisel-shaped crown 8.6 x 6.6 x 10 mm over a root narrowing to 0.8 x 0.7 mm at its apex;
    # the canal (0.8 mm wide) ends 1 mm above it, 0.4 mm from the root's side.
    crown = superellipsoid(0.0, 0.0, 4.5, 4.3, 3.3, 5.5, 2.3) & (z >= -0.5)
    core = superellipsoid(0.0, 0.0, 3.6, 3.3, 2.3, 4.7, 2.3)
    root = ((x / radius(3.2, 0.8)) ** 2 + (y / radius(2.5, 0.7)) ** 2 <= 1.0) & (z <= 0.0) & (z >= -13.0)
    chamber, canal_top, canal_radius = superellipsoid(0.0, 0.0, 3.0, 1.3, 0.8, 2.6, 2.0), 3.0, 0.4
else:
    # Crown: a rounded box 10 x 9 x 8 mm, its cemento-enamel junction at z = 0; enamel 1.4 mm
    # thick on the sides and 1.8 mm over the occlusal table; the root a cone to its apex 13 mm down.
    crown = superellipsoid(0.0, 0.0, 3.0, 5.0, 4.5, 4.5, 2.6) & (z >= -0.5)
    core = superellipsoid(0.0, 0.0, 2.6, 3.6, 3.1, 3.9, 2.6)
    root = ((x / radius(3.8, 0.9)) ** 2 + (y / radius(3.3, 0.8)) ** 2 <= 1.0) & (z <= 0.0) & (z >= -13.0)
    chamber, canal_top, canal_radius = superellipsoid(0.0, 0.0, 2.2, 2.0, 1.7, 1.6, 2.2), 2.2, 0.35
tooth = crown | root
enamel = crown & ~core & (z >= 0.0)
pulp = chamber | ((x ** 2 + y ** 2 <= canal_radius ** 2) & (z >= -12.0) & (z <= canal_top))
pulp &= tooth & ~enamel
filling = None
if CUSTOM and FILLING:
    # An occlusal filling (class I): a box 3 x 2.4 mm across, 2.5 mm deep from the crown's top,
    # through the enamel into the dentin; the tissues it replaced are no longer tooth.
    top = 10.0 if INCISOR else 7.5
    filling = (np.abs(x) <= 1.5) & (np.abs(y) <= 1.2) & (z >= top - 2.5) & crown
    enamel &= ~filling
    pulp &= ~filling
dentin = tooth & ~enamel & ~pulp
if filling is not None:
    dentin &= ~filling

# Grey values in the scanner's units (not HU): each case its own scale and offset.
grey = dict(air=-1000, soft=40, bone=1100, water=0, dentin=1800, enamel=2900, pulp=PULP_HU, scale=1.0, offset=0) if CUSTOM else {
    "jaw": dict(air=-1000, soft=40, bone=1100, dentin=1900, enamel=3000, pulp=40, scale=1.0, offset=0),
    "socket": dict(air=-1000, soft=40, bone=1100, dentin=1900, enamel=3000, pulp=40, scale=1.0, offset=0),
    "air": dict(air=-1000, wax=-80, dentin=1750, enamel=2800, pulp=-1000, scale=0.6, offset=-300),
    "water": dict(air=-1000, water=0, dentin=1800, enamel=2900, pulp=0, scale=2.0, offset=5000),
    "incisor": dict(air=-1000, dentin=1800, enamel=2900, pulp=40, scale=1.0, offset=0),
    "water12": dict(air=0, water=860, dentin=2400, enamel=3500, pulp=900, scale=1.0, offset=0),
    "scaled": dict(air=-1000, dentin=1800, enamel=2900, pulp=40, scale=1.0, offset=0),
    "fine": dict(air=-1000, dentin=1800, enamel=2900, pulp=40, scale=1.0, offset=0),
    "incisor_jaw": dict(air=-1000, soft=40, bone=1100, dentin=1800, enamel=2900, pulp=300, scale=1.0, offset=0),
    "incisor_coarse": dict(air=-1000, dentin=1800, enamel=2900, pulp=300, scale=1.0, offset=0),
    "incisor_jaw_wide": dict(air=-1000, soft=40, bone=1100, dentin=1800, enamel=2900, pulp=40, scale=1.0, offset=0),
    "incisor_jaw_fine": dict(air=-1000, soft=40, bone=1100, dentin=1800, enamel=2900, pulp=40, scale=1.0, offset=0),
}[CASE]
if JAW:
    bone = (z <= -1.5) & (np.abs(x) <= 6.5) & (np.abs(y) <= 9.0)
    if CASE == "socket":  # a 0.3 mm ligament between the root and its socket
        pdl = 0.3
        socket = ((x / (radius(3.8, 0.9) + pdl)) ** 2 + (y / (radius(3.3, 0.8) + pdl)) ** 2 <= 1.0) & (z >= -13.0 - pdl)
        bone &= ~socket
    medium = np.where(bone, grey["bone"], np.where(z <= 3.0, grey["soft"], grey["air"]))
elif CASE == "air":
    medium = np.where(z <= -9.0, grey["wax"], grey["air"]) + 0 * x * y  # root tip in a wax block
elif CASE in ("incisor", "scaled", "fine", "incisor_coarse") or (CUSTOM and MEDIUM == "air"):
    medium = np.full((1, 1, 1), grey["air"]) + 0 * x * y * z
else:
    medium = np.full((1, 1, 1), grey["water"]) + 0 * x * y * z
values = np.where(enamel, grey["enamel"], np.where(dentin, grey["dentin"], np.where(pulp, grey["pulp"], medium)))
if filling is not None:
    values = np.where(filling, float(FILLING), values)
values = values.astype(np.float32)
voxel_mm3 = np.prod(spacing) / FINE ** 3
truth = {name: float(mask.sum() * voxel_mm3) for name, mask in (("enamel", enamel), ("dentin", dentin), ("pulp", pulp))}
if SHADING:  # the tooth on the scan's grid, where the shading's span over it is measured
    in_tooth = tooth.reshape(dims[0], FINE, dims[1], FINE, dims[2], FINE).mean(axis=(1, 3, 5)) > 0.5
metal_share = None
if STREAKS and filling is not None:  # the metal's share of each scan voxel
    metal_share = np.broadcast_to(filling, values.shape).reshape(dims[0], FINE, dims[1], FINE, dims[2], FINE).mean(axis=(1, 3, 5))
del crown, core, root, tooth, enamel, pulp, dentin, medium, filling

# Partial volume (average of the sub-samples), then the scanner's blur and noise.
scan = values.reshape(dims[0], FINE, dims[1], FINE, dims[2], FINE).mean(axis=(1, 3, 5))
del values


def metal_streaks(share, pixel_mm, mu_metal):
    """One axial slice's beam-hardening error (HU): each ray's attenuation through the metal p
    (its path times mu_metal, 1/mm) over 360 angles in [0, pi) read short by STREAKS * p^2, the
    error's sinogram ramp-filtered and back-projected (the scanner's filtered back-projection is
    linear, so only the error needs it)."""
    from scipy import ndimage

    n = int(math.ceil(math.hypot(*share.shape))) + 2
    padded = np.zeros((n, n))
    ox, oy = (n - share.shape[0]) // 2, (n - share.shape[1]) // 2
    padded[ox:ox + share.shape[0], oy:oy + share.shape[1]] = share
    angles = np.linspace(0.0, 180.0, 360, endpoint=False)
    ramp = np.abs(np.fft.fftfreq(n, d=pixel_mm))
    error = np.zeros((n, n))
    for a in angles:
        p = ndimage.rotate(padded, a, reshape=False, order=1).sum(axis=0) * pixel_mm * mu_metal
        filtered = np.real(np.fft.ifft(np.fft.fft(-STREAKS * p ** 2) * ramp))
        error += ndimage.rotate(np.broadcast_to(filtered, (n, n)), -a, reshape=False, order=1)
    error *= math.pi / len(angles)
    return error[ox:ox + share.shape[0], oy:oy + share.shape[1]] * MU_WATER_HU


if metal_share is not None:
    # Attenuation (1/mm) against HU: water's 0.02 at a CBCT's ~70 keV, 1000 HU per MU_WATER.
    MU_WATER = 0.02
    MU_WATER_HU = 1000.0 / MU_WATER
    mu_metal = MU_WATER * (1.0 + float(FILLING) / 1000.0)
    for k in np.nonzero(metal_share.reshape(-1, dims[2]).max(axis=0) > 0.0)[0]:
        scan[:, :, k] += metal_streaks(metal_share[:, :, k], spacing[0], mu_metal)
    del metal_share
sigma_mm = 0.2
freq = np.meshgrid(*[np.fft.fftfreq(n, d=s) for n, s in zip(dims, spacing)], indexing="ij", sparse=True)
transfer = np.exp(-2.0 * math.pi ** 2 * sigma_mm ** 2 * sum(f ** 2 for f in freq))
scan = np.real(np.fft.ifftn(np.fft.fftn(scan) * transfer)).astype(np.float32)
if SHADING:
    c = [(np.arange(n) + 0.5) * s + lo for n, s, (lo, _) in zip(dims, spacing, extent)]
    cx, cy, cz = np.meshgrid(*c, indexing="ij", sparse=True)
    half = [0.5 * (hi - lo) for lo, hi in extent]
    r2 = (cx / half[0]) ** 2 + (cy / half[1]) ** 2
    if SHADING_FORM == "bump":
        field = SHADING * np.exp(-((cx - 4.0) ** 2 + (cy + 3.0) ** 2 + (cz - 2.0) ** 2) / (2.0 * 6.0 ** 2))
    else:
        field = SHADING * (0.5 * r2 - 0.25 + 0.5 * (cz - 0.5 * (extent[2][0] + extent[2][1])) / half[2])
    scan += field.astype(np.float32)
    over_tooth = np.broadcast_to(field, scan.shape)[in_tooth]
    truth_shading = float(np.percentile(over_tooth, 95) - np.percentile(over_tooth, 5))
scan += rng.normal(0.0, 35.0, scan.shape).astype(np.float32)
scan = scan * grey["scale"] + grey["offset"]
if CUSTOM:
    scan = np.clip(scan, -32768, 32767)  # stored as int16

# Placement in the patient (LPS mm): tilted for the jaw, about an arbitrary origin.
tilt = math.radians(15.0 if CASE in ("jaw", "socket") else 0.0)
rotation = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(tilt), -math.sin(tilt)], [0.0, math.sin(tilt), math.cos(tilt)]])
centre_of_first = np.array([lo + s / 2.0 for (lo, _), s in zip(extent, spacing)])
shift = np.array([31.5, -12.25, 140.0])
origin = rotation @ centre_of_first + shift
inside = (rotation @ np.array([0.0, 0.0, -4.0]) + shift).tolist()  # in the root's dentin under the crown

os.makedirs(OUT, exist_ok=True)
if CASE in ("air", "incisor", "water12"):
    import pydicom
    from pydicom.dataset import FileDataset, FileMetaDataset
    from pydicom.uid import ExplicitVRLittleEndian, generate_uid

    path = os.path.join(OUT, "series")
    os.makedirs(path, exist_ok=True)
    # The incisor's scanner stores unsigned values: HU = 0.5 * stored - 1024.
    slope, intercept = (0.5, -1024.0) if CASE == "incisor" else (1.0, 0.0)
    if CASE in ("incisor", "water12"):
        top = 4095 if CASE == "water12" else 65535
        stored = np.clip(np.round((scan - intercept) / slope), 0, top).astype(np.uint16)
    else:
        stored = np.clip(np.round(scan), -32768, 32767).astype(np.int16)
    series, study, frame = generate_uid(), generate_uid(), generate_uid()
    for k in range(dims[2]):
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.2"
        meta.MediaStorageSOPInstanceUID = generate_uid()
        meta.TransferSyntaxUID = ExplicitVRLittleEndian
        ds = FileDataset(None, {}, file_meta=meta, preamble=b"\0" * 128)
        ds.SOPClassUID, ds.SOPInstanceUID = meta.MediaStorageSOPClassUID, meta.MediaStorageSOPInstanceUID
        ds.Modality, ds.SeriesInstanceUID, ds.StudyInstanceUID, ds.FrameOfReferenceUID = "CT", series, study, frame
        ds.InstanceNumber = k + 1
        ds.ImagePositionPatient = [float(v) for v in origin + rotation @ np.array([0.0, 0.0, k * spacing[2]])]
        ds.ImageOrientationPatient = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        ds.PixelSpacing = [spacing[1], spacing[0]]  # row spacing (y), column spacing (x)
        ds.SliceThickness = spacing[2]
        ds.Rows, ds.Columns = dims[1], dims[0]
        ds.SamplesPerPixel, ds.PhotometricInterpretation = 1, "MONOCHROME2"
        bits = 12 if CASE == "water12" else 16
        ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.PixelRepresentation = 16, bits, bits - 1, int(stored.dtype == np.int16)
        ds.RescaleIntercept, ds.RescaleSlope = intercept, slope
        ds.PixelData = np.ascontiguousarray(stored[:, :, k].T).tobytes()  # rows along y, columns along x
        ds.save_as(os.path.join(path, "slice%04d.dcm" % k), write_like_original=False)
else:
    import nibabel

    # NIfTI is RAS: LPS (x, y) negated.
    affine = np.eye(4)
    affine[:3, :3] = np.diag([-1.0, -1.0, 1.0]) @ rotation @ np.diag(spacing)
    affine[:3, 3] = np.diag([-1.0, -1.0, 1.0]) @ origin
    path = os.path.join(OUT, "tooth.nii.gz")
    image = nibabel.Nifti1Image(scan.astype(np.int16 if JAW or CASE in ("scaled", "custom", "gold_incisor", "incisor_water_fine") else np.float32), affine)
    image.set_qform(affine, code=1)
    image.set_sform(affine, code=1)
    if CASE == "scaled":  # the values are 2 * stored - 1000
        image.header.set_slope_inter(2.0, -1000.0)
    nibabel.save(image, path)
print(json.dumps({"path": path, "inside": inside, "truth": truth, **({"shading": truth_shading} if SHADING else {})}))
