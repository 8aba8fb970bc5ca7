#!/usr/bin/env bash
# Regenerates the README's rerun screenshots (docs/images/rerun-surface.png and
# docs/images/rerun-subsurface.png) from real `--viz save` recordings.
#
#   bash docs/make_screenshots.sh            # from the repository root
#
# Not run in CI. Needs the project's venv (.venv, with rerun-sdk and its `rerun`
# viewer binary) and a Vulkan driver for rerun's viewer: a GPU, or Mesa's software
# rasterizer (Debian/Ubuntu: `apt-get install mesa-vulkan-drivers`), which is how
# the committed images were made. No display and no browser are needed: the viewer
# runs headless (`rerun --headless`) and is driven through
# rerun.experimental.ViewerClient (open the .rrd, move the time cursor, save a
# screenshot of the whole viewer window). Pillow (pulled in by matplotlib) scales
# the result down for the README.
#
# Environment: PYTHON (default .venv/bin/python), RERUN_PORT (default 9877, the
# headless viewer's gRPC port on localhost), KEEP (a folder to keep the .rrd
# recordings and full-size screenshots in; default: a temporary one, deleted).
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
python="${PYTHON:-$root/.venv/bin/python}"
bindir="$(dirname "$python")"
export PATH="$bindir:$PATH"   # ViewerClient.spawn looks up `rerun` in PATH
port="${RERUN_PORT:-9877}"
if [[ -n "${KEEP:-}" ]]; then
    work="$(mkdir -p "$KEEP" && cd "$KEEP" && pwd)"
else
    work="$(mktemp -d)"
    trap 'rm -rf "$work"' EXIT
fi

echo "recording the scenes into $work ..."
"$bindir/snakesim" run surface-screw-traverse --duration 3 --viz save "$work/surface.rrd" --quiet
"$bindir/snakesim" run tests/viz/data/moulin-tether.yaml --duration 3 --viz save "$work/moulin.rrd" --quiet

"$python" - "$work" "$port" "$root/docs/images" <<'EOF'
import sys
import time

from PIL import Image
from rerun.experimental import ViewerClient

work, port, images = sys.argv[1], int(sys.argv[2]), sys.argv[3]
shots = [  # (recording, simulated time in s, README image)
    ("surface.rrd", 2.0, "rerun-surface.png"),
    ("moulin.rrd", 1.0, "rerun-subsurface.png"),
]
for rrd, t, name in shots:
    viewer = ViewerClient.spawn(headless=True, port=port, hide_welcome_screen=True)
    try:
        viewer.open([f"{work}/{rrd}"])
        time.sleep(4)                      # let the chunks stream in and the blueprint apply
        viewer.set_time("sim", duration=t, play_state="paused")
        time.sleep(2)                      # a few frames of the software rasterizer
        full = f"{work}/{name}"
        viewer.save_screenshot(full)       # the whole viewer window (1920x1080)
    finally:
        viewer.quit()
    img = Image.open(full).convert("RGB")
    img = img.resize((1400, round(img.height * 1400 / img.width)), Image.LANCZOS)
    img = img.quantize(colors=256, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE)
    img.save(f"{images}/{name}", optimize=True)
    print(f"docs/images/{name} ({rrd} at t = {t:g} s)")
EOF
