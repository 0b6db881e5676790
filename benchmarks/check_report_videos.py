"""Does every ``<video>`` of a report play in a browser? Headless Chromium reads each one.

Usage: ``python benchmarks/check_report_videos.py dexlfd-demo/report.html``

A copy of the report gets a script that, 4 s after the page loaded, writes each
video's ``readyState`` (4 = enough data to play), media error code (4 = source not
supported, e.g. MPEG-4 Part 2) and size into the page; Chromium's ``--dump-dom``
prints it. Needs a ``chromium`` binary (Debian: ``apt-get install chromium``).

Measured on the demo's report: before the overlay went through the H.264 writer,
``capture/overlay.mp4`` read ``readyState=0, error=4`` (blank player) and
``robot.mp4`` ``readyState=4``; after, both ``readyState=4``.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

PROBE = """<script>
function probe(){var v=document.querySelectorAll('video');var out=[];
for(var i=0;i<v.length;i++){var e=v[i].error;out.push(i+': readyState='+v[i].readyState+
', error='+(e?e.code:'none')+', '+v[i].videoWidth+'x'+v[i].videoHeight+
', '+v[i].duration.toFixed(2)+' s');}
var p=document.createElement('pre');p.id='probe';
p.textContent='VIDEOS '+v.length+(out.length?' | '+out.join(' | '):'');
document.body.appendChild(p);}
window.addEventListener('load',function(){setTimeout(probe,4000);});</script></body>"""


def main(report: Path) -> int:
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        print("no chromium on PATH", file=sys.stderr)
        return 2
    probe = report.parent / f".{report.stem}.probe.html"  # beside it: relative links resolve
    probe.write_text(report.read_text().replace("</body>", PROBE))
    try:
        cmd = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--mute-audio",
               "--virtual-time-budget=15000", "--dump-dom", probe.absolute().as_uri()]  # fmt: skip
        dom = subprocess.run(cmd, capture_output=True, text=True, timeout=300).stdout
    finally:
        probe.unlink(missing_ok=True)
    found = re.search(r'<pre id="probe">(VIDEOS[^<]*)', dom)
    if found is None:
        print("the probe did not run", file=sys.stderr)
        return 2
    print(found.group(1).replace(" | ", "\n"))
    states = re.findall(r"readyState=(\d)", found.group(1))
    return 0 if all(s == "4" for s in states) else 1


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1] if len(sys.argv) > 1 else "dexlfd-demo/report.html")))
