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


def load(ns, path=None):
    """Loads DentSim where it is needed, whether or not the server already has it: on the
    client (its proxies in `ns`, the default tissue colours) and, when connected to a pvserver
    that has not loaded it (auto-loaded via PV_PLUGIN_PATH or its settings), on the server too.
    ParaView 5.11 refuses a second remote load of a plugin the server already holds ("No plugin
    loaded yet"), so the server's plugin list is asked first."""
    from paraview import servermanager, simple

    path = path or plugin_path()
    connection = servermanager.ActiveConnection
    if connection is not None and connection.IsRemote():
        manager = servermanager.vtkSMProxyManager.GetProxyManager().GetPluginManager()
        remote = manager.GetRemoteInformation(connection.Session)
        names = [remote.GetPluginName(i) for i in range(remote.GetNumberOfPlugins())
                 if remote.GetPluginLoaded(i)]
        if "DentSim" not in names:
            simple.LoadPlugin(path, remote=True, ns=ns)
    simple.LoadPlugin(path, remote=False, ns=ns)
