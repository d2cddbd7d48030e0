"""Child process for test_editor.py: opens and closes Tactus's editor N times in pedalboard
(needs an X display, e.g. under `xvfb-run`) and prints the resident set size after each cycle.

Usage: python editor_child.py <path to Tactus.vst3> <cycles> <seconds open>
Prints one line per cycle, "CYCLE i RSS_KB n THREADS t FDS f HEAP_KB h", for the first and last
window "DRAWN i BG_PX n ACCENT_PX m PAD_PX p" (pixels of the editor's colours on screen, the
strike pad's own included), then EDITOR-OK. HEAP_KB is
the memory malloc has handed out and not got back (glibc mallinfo2: uordblks + hblkhd; -1 when
unavailable): the leak itself, without the freed memory malloc keeps for reuse, which RSS includes.
"""

import ctypes
import ctypes.util
import os
import sys
import threading
import time

import pedalboard

from conftest import skip_midi_proxies_in_pedalboard


class _Mallinfo2(ctypes.Structure):
    _fields_ = [
        (name, ctypes.c_size_t)
        for name in (
            "arena ordblks smblks hblks hblkhd usmblks fsmblks uordblks fordblks keepcost".split()
        )
    ]


def heap_in_use_kb() -> int:
    try:
        mallinfo2 = ctypes.CDLL(None).mallinfo2  # glibc >= 2.33
    except AttributeError:
        return -1
    mallinfo2.restype = _Mallinfo2
    info = mallinfo2()
    return (info.uordblks + info.hblkhd) // 1024


def status(key: str) -> int:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1])
    raise RuntimeError(f"no {key}")


WM_ATOMS = """_MOTIF_WM_HINTS _NET_WM_WINDOW_TYPE _NET_WM_WINDOW_TYPE_NORMAL _NET_WM_WINDOW_TYPE_DIALOG
_NET_WM_WINDOW_TYPE_COMBO _NET_WM_WINDOW_TYPE_TOOLTIP _NET_WM_WINDOW_TYPE_UTILITY
_KDE_NET_WM_WINDOW_TYPE_OVERRIDE _NET_WM_STATE _NET_WM_STATE_SKIP_TASKBAR _NET_WM_STATE_ABOVE
_NET_WM_STATE_HIDDEN _NET_WM_STATE_FULLSCREEN _NET_WM_STATE_MAXIMIZED_VERT
_NET_WM_STATE_MAXIMIZED_HORZ _NET_WM_ICON _NET_WM_PID _NET_WM_NAME _NET_WM_PING _NET_WM_USER_TIME
_NET_ACTIVE_WINDOW _NET_FRAME_EXTENTS _NET_REQUEST_FRAME_EXTENTS _NET_WM_ALLOWED_ACTIONS
_NET_WM_ACTION_MOVE _NET_WM_ACTION_RESIZE _NET_WM_ACTION_MINIMIZE _NET_WM_ACTION_CLOSE
_NET_WM_ACTION_FULLSCREEN _NET_WM_ACTION_MAXIMIZE_HORZ _NET_WM_ACTION_MAXIMIZE_VERT
_NET_WM_BYPASS_COMPOSITOR _NET_SUPPORTED _NET_SUPPORTING_WM_CHECK WM_CHANGE_STATE WM_STATE
WM_PROTOCOLS WM_DELETE_WINDOW WM_TAKE_FOCUS UTF8_STRING XdndAware XdndEnter XdndLeave
XdndPosition XdndStatus XdndDrop XdndFinished XdndSelection XdndProxy XdndTypeList
XdndActionList XdndActionDescription XdndActionCopy XdndActionPrivate CLIPBOARD TARGETS
COMPOUND_TEXT _NET_WM_WINDOW_OPACITY _GTK_FRAME_EXTENTS""".split()


def own_xsettings():
    """JUCE reads the XSETTINGS manager's window property and gets an X error (BadWindow on window
    0) on a bare X server such as Xvfb, where no desktop runs a settings manager. Become that
    manager with an empty settings list (the display connection must stay open)."""
    x11 = ctypes.CDLL(ctypes.util.find_library("X11"))
    x11.XOpenDisplay.restype = ctypes.c_void_p
    x11.XOpenDisplay.argtypes = [ctypes.c_char_p]
    x11.XDefaultRootWindow.restype = ctypes.c_ulong
    x11.XDefaultRootWindow.argtypes = [ctypes.c_void_p]
    x11.XCreateSimpleWindow.restype = ctypes.c_ulong
    x11.XCreateSimpleWindow.argtypes = [ctypes.c_void_p, ctypes.c_ulong] + [ctypes.c_int] * 2 + [
        ctypes.c_uint
    ] * 3 + [ctypes.c_ulong] * 2
    x11.XInternAtom.restype = ctypes.c_ulong
    x11.XInternAtom.argtypes = [ctypes.c_void_p, ctypes.c_char_p, ctypes.c_int]
    x11.XSetSelectionOwner.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.c_ulong, ctypes.c_ulong]
    x11.XChangeProperty.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.c_ulong, ctypes.c_ulong,
                                    ctypes.c_int, ctypes.c_int, ctypes.c_char_p, ctypes.c_int]
    x11.XFlush.argtypes = [ctypes.c_void_p]
    dpy = x11.XOpenDisplay(None)
    if not dpy:
        raise RuntimeError("no X display (run under xvfb-run)")
    win = x11.XCreateSimpleWindow(dpy, x11.XDefaultRootWindow(dpy), 0, 0, 1, 1, 0, 0, 0)
    settings = x11.XInternAtom(dpy, b"_XSETTINGS_SETTINGS", 0)
    empty = bytes(12)  # byte order LSBFirst, pad, serial 0, 0 settings
    x11.XChangeProperty(dpy, win, settings, settings, 8, 0, empty, len(empty))  # PropModeReplace
    x11.XSetSelectionOwner(dpy, x11.XInternAtom(dpy, b"_XSETTINGS_S0", 0), win, 0)  # CurrentTime
    # JUCE looks some window-manager atoms up with only_if_exists and uses the result (None
    # without a window manager) in XChangeProperty: BadAtom. Create them.
    for name in WM_ATOMS:
        x11.XInternAtom(dpy, name.encode(), 0)
    x11.XFlush(dpy)
    return dpy


class _XImage(ctypes.Structure):
    _fields_ = [
        ("width", ctypes.c_int),
        ("height", ctypes.c_int),
        ("xoffset", ctypes.c_int),
        ("format", ctypes.c_int),
        ("data", ctypes.c_void_p),
        ("byte_order", ctypes.c_int),
        ("bitmap_unit", ctypes.c_int),
        ("bitmap_bit_order", ctypes.c_int),
        ("bitmap_pad", ctypes.c_int),
        ("depth", ctypes.c_int),
        ("bytes_per_line", ctypes.c_int),
        ("bits_per_pixel", ctypes.c_int),
        ("red_mask", ctypes.c_ulong),
        ("green_mask", ctypes.c_ulong),
        ("blue_mask", ctypes.c_ulong),
    ]


# Colours the editor paints (src/plugin/editor/style.rs): the window background BG, the accent
# of the group titles and the TACTUS logo, and the strike pad's velocity wedge (STRIKE_RAMP,
# which nothing else paints).
EDITOR_BG = (0x14, 0x16, 0x1B)
EDITOR_ACCENT = (0xE0, 0x9A, 0x3E)
EDITOR_STRIKE_PAD = (0x4A, 0x35, 0x1F)


def count_editor_pixels(dpy) -> tuple:
    """Grabs the X server's root window (what is on screen, the editor's window included) and
    counts the pixels of the editor's background, accent and strike pad colours. A window that
    never drew (black, or the host's empty frame) has none of them."""
    x11 = ctypes.CDLL(ctypes.util.find_library("X11"))
    x11.XDefaultRootWindow.restype = ctypes.c_ulong
    x11.XDefaultRootWindow.argtypes = [ctypes.c_void_p]
    x11.XGetImage.restype = ctypes.POINTER(_XImage)
    x11.XGetImage.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int, ctypes.c_int,
                              ctypes.c_uint, ctypes.c_uint, ctypes.c_ulong, ctypes.c_int]
    x11.XDestroyImage.argtypes = [ctypes.POINTER(_XImage)]
    x11.XDisplayWidth.argtypes = [ctypes.c_void_p, ctypes.c_int]
    x11.XDisplayHeight.argtypes = [ctypes.c_void_p, ctypes.c_int]
    w, h = x11.XDisplayWidth(dpy, 0), x11.XDisplayHeight(dpy, 0)
    img = x11.XGetImage(dpy, x11.XDefaultRootWindow(dpy), 0, 0, w, h, 0xFFFFFFFF, 2)  # ZPixmap
    if not img:
        return (-1, -1, -1)
    try:
        im = img.contents
        if im.bits_per_pixel != 32:
            return (-1, -1, -1)
        raw = ctypes.string_at(im.data, im.bytes_per_line * im.height)
    finally:
        x11.XDestroyImage(img)
    import numpy as np

    px = np.frombuffer(raw, dtype=np.uint8).reshape(h, -1, 4)[:, :w, :3]  # B, G, R (LSB first)

    def count(rgb):
        r, g, b = rgb
        return int(np.count_nonzero((px[..., 2] == r) & (px[..., 1] == g) & (px[..., 0] == b)))

    return count(EDITOR_BG), count(EDITOR_ACCENT), count(EDITOR_STRIKE_PAD)


# Longest wait for a grabbed window to show the editor's colours, s.
DRAW_WAIT_S = 5.0


def main(path: str, cycles: int, open_s: float, settle_s: float = 0.5) -> None:
    keep = own_xsettings()  # noqa: F841 (keeps the X connection, and the selection, alive)
    skip_midi_proxies_in_pedalboard()
    plugin = pedalboard.load_plugin(path)
    for i in range(cycles):
        close = threading.Event()

        def grab_and_close(i=i):
            # The first and the last window: the editor drew (not only opened). The first open
            # loads fonts and llvmpipe's shaders, which on a loaded machine can take longer than
            # `open_s`: the screen is grabbed again until the editor's colours show, for at most
            # DRAW_WAIT_S, so a window that never draws still reports none.
            if i in (0, cycles - 1):
                deadline = time.monotonic() + DRAW_WAIT_S
                while True:
                    bg, accent, pad = count_editor_pixels(keep)
                    if (bg > 0 and accent > 0 and pad > 0) or time.monotonic() > deadline:
                        break
                    time.sleep(0.1)
                print(f"DRAWN {i} BG_PX {bg} ACCENT_PX {accent} PAD_PX {pad}", flush=True)
            close.set()

        timer = threading.Timer(open_s, grab_and_close)
        timer.start()
        plugin.show_editor(close)  # blocks until `close` is set, then closes the window
        timer.join()
        time.sleep(settle_s)  # the plugin's window thread finishes tearing down asynchronously
        fds = len(os.listdir("/proc/self/fd"))
        print(
            f"CYCLE {i} RSS_KB {status('VmRSS')} THREADS {status('Threads')} FDS {fds} "
            f"HEAP_KB {heap_in_use_kb()}",
            flush=True,
        )
    if os.environ.get("EDITOR_CHILD_FDS"):
        fd_dir = f"/proc/{os.getpid()}/fd"
        links = []
        for f in os.listdir(fd_dir):
            try:
                links.append(os.readlink(f"{fd_dir}/{f}"))
            except OSError:
                pass  # the listing's own descriptor
        print(sorted(links))
    print("EDITOR-OK", flush=True)


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]), float(sys.argv[3]))
