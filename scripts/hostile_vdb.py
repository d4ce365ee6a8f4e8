#!/usr/bin/python3
"""Writes hostile .vdb files derived from valid ones and runs `dentsim prepare` (and `session`
on a sample) on each, counting crashes (signal / abort), hangs (timeout) and outputs left behind.

usage: scripts/hostile_vdb.py DENTSIM OUT_DIR OURS.vdb [--session-every N] [--timeout S]
A run longer than S seconds (default 120) is killed and counted as a hang.
Needs /usr/bin/python3 with Debian's python3-openvdb (for the pyopenvdb-written base and the
wrong-metadata cases)."""
import os, random, subprocess, sys, json, time
import pyopenvdb as vdb

dentsim, out, ours = sys.argv[1], sys.argv[2], sys.argv[3]
opts = dict(zip(sys.argv[4::2], sys.argv[5::2]))
session_every = int(opts.get("--session-every", 10))
timeout = float(opts.get("--timeout", 120))
os.makedirs(out, exist_ok=True)
cases = []  # (name, path)

def case(name, data):
    p = os.path.join(out, name + ".vdb")
    with open(p, "wb") as f:
        f.write(data)
    cases.append((name, p))

# A base written by OpenVDB's own Python module.
py_base = os.path.join(out, "base_py.vdb")
g = vdb.createLevelSetSphere(radius=3.0, center=(0, 0, 0), voxelSize=0.1)
g.name = "dentin"
vdb.write(py_base, grids=[g])

rng = random.Random(11)
for base_name, base in [("ours", ours), ("py", py_base)]:
    data = open(base, "rb").read()
    n = len(data)
    # Truncations at many offsets (dense near the header, spread over the body).
    offsets = sorted(set(list(range(0, min(n, 400), 7)) + [int(n * f / 40) for f in range(1, 40)]))
    for off in offsets:
        case(f"{base_name}_trunc_{off}", data[:off])
    # Byte flips: one, few and many bytes anywhere.
    for i in range(120):
        b = bytearray(data)
        for _ in range(rng.choice([1, 1, 2, 4, 16])):
            pos = rng.randrange(n) if rng.random() < 0.7 else rng.randrange(min(n, 2000))
            b[pos] ^= 1 << rng.randrange(8) if rng.random() < 0.5 else rng.randrange(256)
        case(f"{base_name}_flip_{i}", bytes(b))
    # Appended garbage.
    case(f"{base_name}_append", data + b"\xff" * 1000)

# Wrong metadata types and ranges, absurd voxel sizes, wrong grid classes/value types.
def meta_case(name, **meta):
    gg = vdb.createLevelSetSphere(radius=3.0, center=(0, 0, 0), voxelSize=0.1)
    gg.name = "dentin"
    for k, v in meta.items():
        gg[k] = v
    p = os.path.join(out, name + ".vdb")
    vdb.write(p, grids=[gg])
    cases.append((name, p))

meta_case("meta_stiffness_string", stiffness_n_per_mm="hard")
meta_case("meta_damping_string", damping_n_s_per_mm="x")
meta_case("meta_removal_vec", removal_rate_mm3_per_n_s=(1.0, 2.0, 3.0))
meta_case("meta_stiffness_negative", stiffness_n_per_mm=-5.0)
meta_case("meta_stiffness_nan", stiffness_n_per_mm=float("nan"))
meta_case("meta_stiffness_inf", stiffness_n_per_mm=float("inf"))
meta_case("meta_opacity_2", opacity=2.0)
meta_case("meta_colour_string", colour="red")
meta_case("meta_colour_big", colour=(5.0, 0.0, 0.0))
meta_case("meta_fdi_huge", fdi_tooth=100000)
meta_case("meta_fdi_string", fdi_tooth="36")
meta_case("meta_source_number", source=3.0)
meta_case("meta_tissue_number", tissue=1.0)
meta_case("meta_bool", stiffness_n_per_mm=True)

for name, vs in [("voxel_0.001", 0.001), ("voxel_20", 20.0)]:
    gg = vdb.createLevelSetSphere(radius=3.0, center=(0, 0, 0), voxelSize=0.1)
    gg.name = "dentin"
    gg.transform = vdb.createLinearTransform(voxelSize=vs)
    p = os.path.join(out, name + ".vdb"); vdb.write(p, grids=[gg]); cases.append((name, p))
gg = vdb.createLevelSetSphere(radius=3.0, center=(0, 0, 0), voxelSize=0.1)
gg.name = "dentin"
gg.transform = vdb.createLinearTransform([[0.1, 0, 0, 0], [0, 0.3, 0, 0], [0, 0, 0.1, 0], [0, 0, 0, 1]])
p = os.path.join(out, "voxel_nonuniform.vdb"); vdb.write(p, grids=[gg]); cases.append(("voxel_nonuniform", p))
gg = vdb.createLevelSetSphere(radius=3.0, center=(0, 0, 0), voxelSize=0.1)
gg.name = "dentin"; gg.gridClass = vdb.GridClass.FOG_VOLUME
p = os.path.join(out, "class_fog.vdb"); vdb.write(p, grids=[gg]); cases.append(("class_fog", p))
dg = vdb.Vec3SGrid(); dg.name = "dentin"; dg.gridClass = vdb.GridClass.LEVEL_SET
dg.fill((0, 0, 0), (10, 10, 10), (1.0, 0.0, 0.0))
p = os.path.join(out, "type_vec3.vdb"); vdb.write(p, grids=[dg]); cases.append(("type_vec3", p))
# Active voxels spanning a huge box (a session would voxelize the inside).
big = vdb.FloatGrid(background=0.3); big.name = "dentin"; big.gridClass = vdb.GridClass.LEVEL_SET
big.transform = vdb.createLinearTransform(voxelSize=0.05)
acc = big.getAccessor()
acc.setValueOn((0, 0, 0), -0.1); acc.setValueOn((200000, 200000, 200000), -0.1)
p = os.path.join(out, "bbox_huge.vdb"); vdb.write(p, grids=[big]); cases.append(("bbox_huge", p))
bg = vdb.createLevelSetSphere(radius=3.0, center=(0, 0, 0), voxelSize=0.1); bg.name = "dentin"
bg.background = float("nan")
p = os.path.join(out, "background_nan.vdb"); vdb.write(p, grids=[bg]); cases.append(("background_nan", p))

csv = os.path.join(out, "plunge.csv")
open(csv, "w").write("t,x,y,z,qw,qx,qy,qz\n0,0,0,4,1,0,0,0\n1,0,0,2,1,0,0,0\n")

def run(args, dest):
    t0 = time.time()
    try:
        r = subprocess.run(args, capture_output=True, timeout=timeout, env=dict(os.environ, RUST_BACKTRACE="0"))
    except subprocess.TimeoutExpired:
        return {"rc": "hang", "secs": timeout}
    err = r.stderr.decode("utf-8", "replace")
    crashed = r.returncode < 0 or r.returncode in (134, 139) or "panicked" in err or "terminate called" in err
    left = sorted(os.listdir(dest)) if os.path.isdir(dest) else []
    return {"rc": r.returncode, "crash": crashed, "stderr_bytes": len(r.stderr), "stderr_lines": err.count("\n"),
            "secs": round(time.time() - t0, 2), "err": err.strip().splitlines()[-1][:300] if err.strip() else "",
            "left": left}

results = []
progress = open(os.path.join(out, "progress.jsonl"), "w")
for i, (name, p) in enumerate(cases):
    dest = os.path.join(out, "out_" + name)
    r = run([dentsim, "prepare", p, "--path", csv, "--burr", "round:1.0", "--out", dest], dest)
    r.update(name=name, cmd="prepare")
    results.append(r)
    progress.write(json.dumps(r) + "\n"); progress.flush()
    if i % session_every == 0 or name.startswith(("meta", "voxel", "bbox", "class", "type", "background")):
        dest = os.path.join(out, "sess_" + name)
        r = run([dentsim, "session", "--tissues", p, "--device", "scripted:" + csv, "--out", dest], dest)
        r.update(name=name, cmd="session")
        results.append(r)
        progress.write(json.dumps(r) + "\n"); progress.flush()

json.dump(results, open(os.path.join(out, "results.json"), "w"), indent=1)
accepted = [r for r in results if r["rc"] == 0]
summary = {
    "files": len(cases), "runs": len(results),
    "crashes": sum(1 for r in results if r.get("crash")),
    "hangs": sum(1 for r in results if r["rc"] == "hang"),
    "errors_over_one_line": sum(1 for r in results if r["rc"] not in (0, "hang") and r["stderr_lines"] > 1),
    "stderr_over_4k": sum(1 for r in results if r.get("stderr_bytes", 0) > 4096),
    "failed_with_outputs_left": sum(1 for r in results if r["rc"] not in (0, "hang") and r.get("left")),
    "accepted": len(accepted),
    "slowest_s": max(r["secs"] for r in results),
}
print(json.dumps(summary))
for r in results:
    if r.get("crash") or r["rc"] == "hang" or r.get("stderr_bytes", 0) > 4096 or (r["rc"] not in (0, "hang") and r.get("left")):
        print(r["cmd"], r["name"], r["rc"], r.get("err", "")[:160], r.get("left", ""))
for r in results:
    if r["rc"] == 0 and r["name"].startswith(("meta", "voxel", "bbox", "class", "type", "background")):
        print("ACCEPTED", r["cmd"], r["name"])
