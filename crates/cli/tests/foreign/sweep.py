"""The wider sweep of scans dentsim has never seen (not part of the test run: ~5 minutes): every
tooth `foreign_tooth.py custom` makes from molar and incisor, in air, water and a jaw, at 0.1–0.4
mm, with a pulp of 40 or 300 HU (84 scans), through `dentsim segment`. One line per scan: within
issue 12's goals for unseen scans (enamel and dentin 5 %, pulp 8 %) or a miss, its errors and
warnings, or the refusal; then the counts. Run two builds on the same scans to compare them.

    python3 sweep.py DENTSIM [ONLY...]

DENTSIM: the dentsim binary; ONLY: run only the scans whose name holds one of these (e.g. jaw_0.1).
FILLING=HU in the environment gives every tooth an occlusal metal filling of that grey (e.g. 12000;
30000, gold's range; 40000, which the int16 storage clips at 32767), and STREAKS=B with it that
filling's beam hardening (each axial ray through the metal short by B times its attenuation
squared, reconstructed by filtered back-projection; 0.1-0.3 taken as a metal's). SHADING=HU puts every scan
under a cone-beam scanner's shading (cupping and a ramp along the axis; SHADING_FORM=bump instead a
Gaussian hump of that height).
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
GOAL = {"enamel": 5.0, "dentin": 5.0, "pulp": 8.0}


def one(dentsim, name, params, work):
    env = dict(os.environ, **params, SEED=str(zlib.crc32(name.encode()) % 1000))
    made = json.loads(subprocess.run([sys.executable, os.path.join(HERE, "foreign_tooth.py"), work, "custom"], env=env,
                                     capture_output=True, text=True, check=True).stdout)
    out = os.path.join(work, "tissues.vdb")
    run = subprocess.run([dentsim, "segment", made["path"], "--voxel", "0.1", "--point", ",".join(str(v) for v in made["inside"]), "--out", out],
                         env=dict(os.environ, RUST_BACKTRACE="0"), capture_output=True, text=True)
    if run.returncode != 0:
        return "refused", (run.stderr.strip().splitlines() or [""])[-1][:160]
    report = json.load(open(out + ".json"))
    found = {t["name"]: t["volume_mm3"] for t in report["tissues"]}
    errors = {k: 100.0 * (found.get(k, 0.0) / made["truth"][k] - 1.0) for k in GOAL}
    verdict = "within" if all(abs(errors[k]) <= GOAL[k] for k in GOAL) else "miss"
    said = "; ".join(w[:70] for w in report["warnings"])
    return verdict, " ".join("%s %+.1f %%" % (k, e) for k, e in errors.items()) + (" | warned: " + said if said else "")


def main():
    dentsim, only = sys.argv[1], sys.argv[2:]
    counts = {}
    for shape in ("molar", "incisor"):
        for medium in ("air", "water", "jaw"):
            for voxel in ("0.1", "0.15", "0.2", "0.25", "0.3", "0.35", "0.4"):
                for pulp in ("40", "300"):
                    name = "%s_%s_%s_%s" % (shape, medium, voxel, pulp)
                    if only and not any(o in name for o in only):
                        continue
                    work = tempfile.mkdtemp(prefix="sweep_")
                    try:
                        verdict, text = one(dentsim, name, dict(SHAPE=shape, MEDIUM=medium, VOXEL=voxel, PULP=pulp), work)
                    finally:
                        shutil.rmtree(work, ignore_errors=True)
                    counts[verdict] = counts.get(verdict, 0) + 1
                    print("%-22s %-7s %s" % (name, verdict, text), flush=True)
    print(", ".join("%s %d" % kv for kv in sorted(counts.items())))


if __name__ == "__main__":
    main()
