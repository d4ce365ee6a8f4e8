#!/usr/bin/python3
"""Issue 11's hostile inputs, run against one or two dentsim binaries (before / after a change).

    /usr/bin/python3 scripts/hostile_cases.py target/release/dentsim [OTHER_DENTSIM]

Builds every case under a temporary folder (pydicom, nibabel and pyopenvdb from Debian), runs each
command under a 60 s timeout and a 12 GB address-space limit, and prints per binary: exit code
(124 = hang, 134/139 = crash), seconds, peak memory, the first line of stderr and what was left in
the output folder. The Rust tests hold the same cases as assertions; this script is for the
before/after table.
"""
import os, shutil, struct, subprocess, sys, tempfile, time, warnings

import nibabel as nib
import numpy as np
import pydicom
import pyopenvdb as vdb

warnings.filterwarnings("ignore", message="Invalid value for VR DS")  # the NaN slope is the point


def make_cases(bin_, root):
    c = os.path.join(root, "cases")
    os.makedirs(c)
    subprocess.run([bin_, "phantom", "--format", "dicom", "--out", f"{root}/series"], check=True, capture_output=True)
    subprocess.run([bin_, "phantom", "--format", "nifti", "--out", f"{root}/scan.nii.gz"], check=True, capture_output=True)
    subprocess.run([bin_, "phantom", "--format", "mha", "--out", f"{root}/scan.mha"], check=True, capture_output=True)

    def series(name, edit=None, which=None):
        d = f"{c}/{name}"
        shutil.copytree(f"{root}/series", d)
        files = sorted(os.listdir(d))
        for f in (files if which is None else [files[i] for i in which]) if edit else []:
            ds = pydicom.dcmread(f"{d}/{f}")
            edit(ds)
            ds.save_as(f"{d}/{f}")
        return d, files

    d, _ = series("dicom_zero_byte_extra")
    open(f"{d}/zzz_empty.dcm", "w").close()
    d, _ = series("dicom_text_extra")
    open(f"{d}/README.txt", "w").write("exported by hand\n")
    series("dicom_slope_nan_all", lambda ds: setattr(ds, "RescaleSlope", "NaN"))
    series("dicom_slope0_one", lambda ds: setattr(ds, "RescaleSlope", "0"), [60])

    def bits8(ds):
        ds.BitsAllocated, ds.BitsStored, ds.HighBit = 8, 8, 7

    series("dicom_bits8_one", bits8, [60])
    d, files = series("dicom_intercept_text_one")
    p = f"{d}/{files[60]}"
    raw = open(p, "rb").read()
    i = raw.find(b"\x28\x00\x52\x10DS")  # RescaleIntercept, explicit VR little endian
    n = struct.unpack("<H", raw[i + 6 : i + 8])[0]
    open(p, "wb").write(raw[: i + 8] + b"abc".ljust(n)[:n] + raw[i + 8 + n :])
    d, files = series("dicom_truncated_slice")
    p = f"{d}/{files[60]}"
    head = open(p, "rb").read()[:300]
    open(p, "wb").write(head)
    d, files = series("dicom_zero_byte_slice")
    open(f"{d}/{files[60]}", "wb").close()
    ds = pydicom.dcmread(pydicom.data.get_testdata_file("CT_small.dcm"))
    ds.Rows = ds.Columns = 16384  # 512 MiB of pixels claimed by a 39 KB file
    ds.save_as(f"{c}/big_claim.dcm")

    b = bytearray(open(f"{root}/scan.nii.gz", "rb").read())
    b[-8] ^= 0xFF  # the gzip CRC
    open(f"{c}/crc.nii.gz", "wb").write(bytes(b))
    img = nib.load(f"{root}/scan.nii.gz")
    tiny = nib.Nifti1Image(np.asarray(img.dataobj), np.diag([1e-11, 1e-11, 1e-11, 1]))
    nib.save(tiny, f"{c}/tiny_spacing.nii.gz")
    t = open(f"{root}/scan.mha", "rb").read()
    head = t[: t.find(b"ElementDataFile")].replace(b"BinaryData = True", b"BinaryData = False")
    open(f"{c}/ascii.mha", "wb").write(head + b"ElementDataFile = LOCAL\n1 2 3\n")

    rows = "0,0,0,6,1,0,0,0,200000,1\n0.5,0,0,4.5,1,0,0,0,200000,1\n1.0,0,0,6,1,0,0,0,200000,0\n"
    open(f"{c}/dup_col.csv", "w").write("t,x,y,z,qw,qx,qy,qz,rpm,x\n" + rows)
    open(f"{c}/bom.csv", "w", encoding="utf-8-sig").write("t,x,y,z,qw,qx,qy,qz,rpm,cut\n" + rows)
    open(f"{c}/good.csv", "w").write("t,x,y,z,qw,qx,qy,qz,rpm,cut\n" + rows)
    open(f"{c}/long_t.csv", "w").write("t,x,y,z,qw,qx,qy,qz,rpm,cut\n" + rows + "1e12,0,0,6,1,0,0,0,200000,0\n")
    open(f"{c}/dup_tissue.toml", "w").write('[[tissue]]\nname = "enamel"\nstiffness_n_per_mm = 5\n[[tissue]]\nname = "enamel"\nstiffness_n_per_mm = 9\n')
    g = vdb.createLevelSetSphere(radius=3.0, center=(0, 0, 0), voxelSize=0.08)
    g.name = "enamel"
    vdb.write(f"{c}/sphere.vdb", grids=[g])
    g = vdb.createLevelSetSphere(radius=0.05, center=(0, 0, 0), voxelSize=0.001, halfWidth=3.0)
    g.name = "enamel"
    vdb.write(f"{c}/fine.vdb", grids=[g])
    return c


def cases(c, root):
    ser = f"{root}/series"
    seg = lambda src, *more: ["segment", src, "--out", "OUT/t.vdb", *more]
    sphere = f"{c}/sphere.vdb"
    hand = "hand:start=0:0:5,target=0:0:2"
    return {
        "dicom: zero-byte extra file": seg(f"{c}/dicom_zero_byte_extra"),
        "dicom: text extra file": seg(f"{c}/dicom_text_extra"),
        "dicom: RescaleSlope NaN, all": seg(f"{c}/dicom_slope_nan_all"),
        "dicom: RescaleSlope 0, one": seg(f"{c}/dicom_slope0_one"),
        "dicom: intercept 'abc', one": seg(f"{c}/dicom_intercept_text_one"),
        "dicom: BitsAllocated 8, one": seg(f"{c}/dicom_bits8_one"),
        "dicom: truncated slice": seg(f"{c}/dicom_truncated_slice"),
        "dicom: zero-byte slice": seg(f"{c}/dicom_zero_byte_slice"),
        "dicom: 39 KB claiming 512 MiB": seg(f"{c}/big_claim.dcm"),
        "nifti: gzip CRC wrong": seg(f"{c}/crc.nii.gz"),
        "nifti: 1e-11 mm spacing": seg(f"{c}/tiny_spacing.nii.gz"),
        "mha: BinaryData = False": seg(f"{c}/ascii.mha"),
        "segment --point nan,0,0": seg(ser, "--point", "nan,0,0"),
        "segment --tooth 37": seg(ser, "--tooth", "37"),
        "toml: tissue twice": seg(ser, "--tissues", f"{c}/dup_tissue.toml"),
        "csv: duplicate column": ["prepare", sphere, "--path", f"{c}/dup_col.csv", "--burr", "round:1.0", "--out", "OUT"],
        "csv: UTF-8 BOM": ["prepare", sphere, "--path", f"{c}/bom.csv", "--burr", "round:1.0", "--out", "OUT"],
        "prepare --path /dev/zero": ["prepare", sphere, "--path", "/dev/zero", "--burr", "round:1.0", "--out", "OUT"],
        "session scripted:/dev/zero": ["session", "--tissues", sphere, "--device", "scripted:/dev/zero", "--out", "OUT"],
        "session path last t = 1e12 s": ["session", "--tissues", sphere, "--device", f"scripted:{c}/long_t.csv", "--out", "OUT"],
        "session hand damping=-5": ["session", "--tissues", sphere, "--device", f"{hand},damping=-5,duration=0.2", "--out", "OUT"],
        "session hand duration=1e12": ["session", "--tissues", sphere, "--device", f"{hand},duration=1e12", "--out", "OUT"],
        "session 0.001 mm voxels": ["session", "--tissues", f"{c}/fine.vdb", "--device", f"{hand},duration=0.2", "--out", "OUT"],
        "prepare 0.001 mm voxels": ["prepare", f"{c}/fine.vdb", "--path", f"{c}/good.csv", "--burr", "round:1.0", "--out", "OUT"],
    }


def run(bin_, name, args, work):
    out = os.path.join(work, "".join(ch if ch.isalnum() else "_" for ch in name))
    args = [a.replace("OUT", out) for a in args]
    if args[0] == "segment":
        os.makedirs(out)  # older builds did not create the report's folder
    t = time.time()
    p = subprocess.run(["/usr/bin/time", "-f", "MAXRSS %M", "timeout", "60", "prlimit", "--as=12000000000", bin_, *args],
                       capture_output=True, text=True, errors="replace", env={**os.environ, "RUST_BACKTRACE": "0"})
    lines = [l for l in p.stderr.splitlines() if l.strip()]
    rss = next((int(l.split()[1]) // 1024 for l in lines if l.startswith("MAXRSS")), -1)
    err = next((l for l in lines if not l.startswith("MAXRSS") and "exited with non-zero" not in l), "")
    note = next((l for l in p.stdout.splitlines() if "label" in l), "")
    left = sorted(os.listdir(out)) if os.path.isdir(out) else None
    return p.returncode, time.time() - t, rss, (err or note)[:150], left


def main():
    bins = sys.argv[1:]
    root = tempfile.mkdtemp(prefix="dentsim-hostile-")
    c = make_cases(bins[0], root)
    for i, b in enumerate(bins):
        work = os.path.join(root, f"run{i}")
        os.makedirs(work)
        print(f"== {b}")
        for name, args in cases(c, root).items():
            rc, dt, rss, msg, left = run(b, name, args, work)
            print(f"{name:31} rc={rc:<4} {dt:5.1f} s {rss:5} MB  {msg}  left={left}", flush=True)
    shutil.rmtree(root)


if __name__ == "__main__":
    main()
