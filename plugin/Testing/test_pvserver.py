"""Client–server: a pvserver on loopback, once with DentSim auto-loaded (PV_PLUGIN_PATH) and
once without; each time pvpython connects, loads the plugin as the README says and plans a
preparation on the server."""
import argparse
import os
import socket
import subprocess
import sys
import time

parser = argparse.ArgumentParser()
parser.add_argument("--pvserver", required=True)
parser.add_argument("--pvpython", required=True)
parser.add_argument("--plugin", required=True)
parser.add_argument("--examples", required=True)
parser.add_argument("--temp", required=True)
args = parser.parse_args()

csv = os.path.join(args.temp, "pvserver_groove.csv")
with open(csv, "w") as f:
    f.write("t,x,y,z,qw,qx,qy,qz,cut\n0,-1.5,0,5.6,1,0,0,0,0\n")
    for i in range(31):
        f.write("%.2f,%.2f,0,4.0,1,0,0,0,1\n" % (0.01 * (i + 1), -1.5 + 0.1 * i))


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


failed = False
for autoload in (True, False):
    port = free_port()
    env = dict(os.environ)
    env.pop("PV_PLUGIN_PATH", None)
    if autoload:
        env["PV_PLUGIN_PATH"] = os.path.dirname(args.plugin)
    server = subprocess.Popen([args.pvserver, "--server-port=%d" % port, "--hostname=localhost"],
                              env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        for _ in range(100):  # until it listens
            with socket.socket() as s:
                if s.connect_ex(("127.0.0.1", port)) == 0:
                    break
            time.sleep(0.1)
        # The client runs without PV_PLUGIN_PATH: what it has, it loads itself.
        client_env = dict(os.environ)
        client_env.pop("PV_PLUGIN_PATH", None)
        client = subprocess.run([args.pvpython, os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                                              "test_pvserver_client.py"),
                                 "--port", str(port), "--plugin", args.plugin, "--examples", args.examples,
                                 "--csv", csv], env=client_env, capture_output=True, text=True, timeout=240)
    finally:
        try:
            out, _ = server.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            server.kill()
            out, _ = server.communicate()
    what = "server with DentSim auto-loaded" if autoload else "server without DentSim"
    if "PASSED client" in client.stdout:
        print("%s: %s" % (what, client.stdout.strip().splitlines()[0]))
    else:
        print("FAILED: %s\n--- client\n%s\n%s\n--- server\n%s" % (what, client.stdout, client.stderr, out))
        failed = True
sys.exit(1 if failed else 0)
