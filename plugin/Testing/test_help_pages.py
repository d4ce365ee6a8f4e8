"""The plugin's help pages: built from each proxy's XML documentation into the compressed help
(.qch) compiled into DentSim.so, one page per source, filter and reader, with its documentation."""
import glob
import os
import re
import sqlite3
import sys
import zlib

qch, xml_dir = sys.argv[1], sys.argv[2]
proxies = []
for xml in sorted(glob.glob(os.path.join(xml_dir, "*.xml"))):
    text = open(xml).read()
    group = re.search(r'<ProxyGroup name="(\w+)"', text).group(1)
    for name in re.findall(r'<SourceProxy name="(\w+)"', text):
        proxies.append(("%s.%s.html" % (group, name), re.search(r'short_help="([^"]+)"', text).group(1)))
db = sqlite3.connect(qch)
files = {}
for name, data in db.execute(
        "SELECT n.Name, d.Data FROM FileNameTable n JOIN FileDataTable d ON n.FileId = d.Id"):
    if data is None:
        continue
    files[name] = zlib.decompress(bytes(data)[4:]).decode("utf-8", "replace")  # qCompress: 4-byte size first
failed = False
for page, short_help in proxies:
    if page not in files:
        print("FAILED: no help page %s (pages: %s)" % (page, sorted(files)))
        failed = True
    elif short_help.split(";")[0] not in files[page]:
        print("FAILED: %s lacks its documentation %r" % (page, short_help))
        failed = True
    else:
        print("help page %s" % page)
sys.exit(1 if failed or not proxies else 0)
