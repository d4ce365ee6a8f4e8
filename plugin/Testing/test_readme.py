"""The README's Python snippet, verbatim, run by pvpython from an empty folder outside the
checkout, with DENTSIM_PLUGIN and DENTSIM set as the README says."""
import argparse
import ast
import os
import subprocess
import sys
import tempfile

parser = argparse.ArgumentParser()
parser.add_argument("--pvpython", required=True)
parser.add_argument("--readme", required=True)
parser.add_argument("--plugin", required=True)
parser.add_argument("--dentsim", required=True)
args = parser.parse_args()

text = open(args.readme).read()
start = text.index("```python\n", text.index("the snippet then runs from any folder")) + len("```python\n")
snippet = text[start:text.index("```", start)]
folder = tempfile.mkdtemp(prefix="dentsim-readme-")
with open(os.path.join(folder, "snippet.py"), "w") as f:
    f.write(snippet)
env = dict(os.environ, DENTSIM_PLUGIN=args.plugin, DENTSIM=args.dentsim)
run = subprocess.run([args.pvpython, "snippet.py"], cwd=folder, env=env, capture_output=True, text=True, timeout=300)
last = run.stdout.strip().splitlines()[-1] if run.stdout.strip() else ""
try:
    removed = ast.literal_eval(last)
except (ValueError, SyntaxError):
    removed = {}
if run.returncode != 0 or not removed.get("enamel", 0) > 0.5:
    print(run.stdout, run.stderr)
    print("FAILED: the README snippet (exit %d, printed %r)" % (run.returncode, last))
    sys.exit(1)
print("README snippet from %s: removed %s" % (folder, removed))
