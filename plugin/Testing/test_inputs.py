"""Inputs the plugin tests make, and the GUI drivers' arguments. Free of ParaView: the GUI tests'
drivers run under plain python3."""
import argparse
import re
import subprocess


def phantom_scan(dentsim, path, fmt="mha"):
    """Writes the built-in phantom's scan to `path` (`dentsim phantom`); the point (LPS mm) near
    its tooth 36, as the command prints it."""
    made = subprocess.run([dentsim, "phantom", "--format", fmt, "--out", path],
                          check=True, capture_output=True, text=True).stdout
    return [float(v) for v in re.search(r"near ([-\d.]+),([-\d.]+),([-\d.]+) mm", made).groups()]


def occlusal_groove(path):
    """A tool path 2 mm into the phantom's tooth 36 occlusal table, along x, the burr upright."""
    with open(path, "w") as f:
        f.write("t,x,y,z,qw,qx,qy,qz,cut\n0,21,18,-26.6,1,0,0,0,0\n")
        f.writelines("%.2f,%.2f,18,-29.6,1,0,0,0,1\n" % (0.01 * (i + 1), 21 + 0.1 * i) for i in range(61))


def gui_driver_args(*extra):
    """The GUI drivers' arguments; `extra` names further required ones (e.g. "--pvbatch")."""
    parser = argparse.ArgumentParser()
    for name in ("--paraview", "--plugin", "--dentsim", "--temp", "--baselines") + extra:
        parser.add_argument(name, required=True)
    parser.add_argument("--update-baseline", action="store_true")
    return parser.parse_args()
