#!/usr/bin/env bash
# Regenerates docs/editor.png: the standalone (dummy audio backend, no device needed) under a
# virtual X server, its window grabbed once the editor has drawn.
#
# Needs: xvfb (Xvfb), x11-apps (xwd) and imagemagick (convert), plus the editor/standalone build
# headers of .ci/test. Debian: apt-get install xvfb x11-apps imagemagick
#
# Usage: scripts/editor-screenshot.sh [output.png]   (default docs/editor.png)
# Env: TACTUS_SCREENSHOT_WAIT seconds to let the editor draw (default 6);
#      TACTUS_SCREENSHOT_PROFILE cargo profile of the build (default release; `dev` reuses the
#      test build's dependencies, and the editor looks the same).
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-docs/editor.png}"
wait_s="${TACTUS_SCREENSHOT_WAIT:-6}"

for tool in Xvfb xwd convert; do
    command -v "$tool" >/dev/null || {
        echo "error: $tool not found; apt-get install xvfb x11-apps imagemagick" >&2
        exit 1
    }
done

profile="${TACTUS_SCREENSHOT_PROFILE:-release}"
cargo build --profile "$profile" --features standalone --bin tactus-standalone
if [ "$profile" = dev ]; then bin=target/debug/tactus-standalone; else bin="target/$profile/tactus-standalone"; fi

# A free display number: the first without an X lock file.
display=99
while [ -e "/tmp/.X${display}-lock" ]; do display=$((display + 1)); done
# 24-bit colour; big enough for the editor's default size (980×775 logical points, scale 1).
Xvfb ":$display" -screen 0 1100x860x24 -nolisten tcp >/dev/null 2>&1 &
xvfb_pid=$!
app_pid=
tmp=$(mktemp -d)
cleanup() {
    [ -n "$app_pid" ] && kill "$app_pid" 2>/dev/null || true
    kill "$xvfb_pid" 2>/dev/null || true
    rm -rf "$tmp"
}
trap cleanup EXIT
for _ in $(seq 50); do
    [ -e "/tmp/.X11-unix/X${display}" ] && break
    sleep 0.1
done

DISPLAY=":$display" "$bin" --backend dummy >"$tmp/app.log" 2>&1 &
app_pid=$!
sleep "$wait_s"
if ! kill -0 "$app_pid" 2>/dev/null; then
    echo "error: tactus-standalone exited early:" >&2
    cat "$tmp/app.log" >&2
    exit 1
fi

# Without a window manager the editor's window sits at the root's top-left corner; the root
# is grabbed and trimmed to the window (the rest of the root is black).
DISPLAY=":$display" xwd -root -silent >"$tmp/root.xwd"
convert "$tmp/root.xwd" -trim +repage "$tmp/editor.png"
# A window that never drew is uniform (or black, and trimmed away entirely).
colours=$(convert "$tmp/editor.png" -format '%k' info:)
if [ "$colours" -lt 16 ]; then
    echo "error: the grabbed window has $colours colours; the editor did not draw" >&2
    exit 1
fi
# Strip the PNG's time stamps so that an unchanged editor gives an unchanged file.
convert "$tmp/editor.png" -strip "$out"
echo "wrote $out ($(convert "$out" -format '%wx%h' info:), $colours colours)"
