"""Where the DentSim plugin is, for the examples: $DENTSIM_PLUGIN, else this checkout's build
(build/plugin/...), so the examples run from any folder."""
import os

HERE = os.path.dirname(os.path.abspath(__file__))
BUILT = os.path.join(HERE, "..", "..", "build", "plugin", "lib", "paraview-5.11", "plugins", "DentSim", "DentSim.so")


def plugin_path():
    path = os.environ.get("DENTSIM_PLUGIN") or os.path.normpath(BUILT)
    if not os.path.exists(path):
        raise SystemExit("DentSim plugin not found at %s: build it (README) or set DENTSIM_PLUGIN" % path)
    return path
