"""The studio in headless Chromium (Debian's chromium, chromium-driver, python3-selenium).

  /usr/bin/python3 studio_browser.py --ballvision BIN --calib FILE --seq DIR --out DIR
                                     [--live tcp:HOST:PORT --live-end CMD]

Sequence mode: the page loads the captured sequence and shows both cameras' annotated frames; the
top view draws the ball where `ballvision run` (run here, separately) puts it, and the canvas
pixel there is the ball's colour; a click on the ball in the perspective image teaches its
colour (the report names the model, the frames are classified again and the picture changes);
a folder that is not a sequence gives a clear message. Live mode (--live): the page shows the
device's ball states and status counters; after --live-end (a shell command that ends the
device) it says the link ended, and the page still answers. Screenshots land in --out.
Exit 0 when every check passed; each check prints one line."""
import argparse
import contextlib
import csv
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import urllib.request


def _skip(why):
    if os.environ.get("CI") == "true":  # tools/dev.sh installs them: missing is a failure
        raise SystemExit(f"FAIL: {why} (CI=true: tools/dev.sh deps installs it)")
    print(f"SKIP: {why}")
    sys.exit(77)


try:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
except ImportError:
    _skip("python3-selenium is not installed")
for _exe in ("/usr/bin/chromium", "/usr/bin/chromedriver"):
    if not os.access(_exe, os.X_OK):
        _skip(f"{_exe} is not installed (Debian chromium, chromium-driver)")

HERE = os.path.dirname(os.path.abspath(__file__))
FAILED = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what, flush=True)
    if not ok:
        FAILED.append(what)
    return ok


def wait_for(fn, seconds, what):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        try:
            v = fn()
            if v:
                return v
        except Exception:  # noqa: BLE001 - the page may be between states
            pass
        time.sleep(0.2)
    check(False, f"{what} (waited {seconds} s)")
    return None


def start_studio(a, source, extra=()):
    env = dict(os.environ, PYTHONPATH=os.path.join(HERE, ".."))
    p = subprocess.Popen([sys.executable, "-m", "ballvision_link.studio", source, "--calib",
                          a.calib, "--port", "0", "--ballvision", a.ballvision,
                          "--work", os.path.join(a.out, "work_" + str(len(os.listdir(a.out)))),
                          *extra], env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                         text=True)
    line = p.stdout.readline()
    m = re.search(r"(http://\S+/)", line)
    if not m:
        p.kill()
        raise SystemExit(f"studio did not start: {line}{p.stdout.read()}")
    return p, m.group(1)


@contextlib.contextmanager
def browser():
    # Chromium leaves its profile and singleton socket in TMPDIR after quit: a private one (short:
    # the socket path must fit a sockaddr_un), removed afterwards, keeps /tmp clean.
    tmp = tempfile.mkdtemp(prefix="bv-chromium-")
    o = webdriver.ChromeOptions()
    o.binary_location = "/usr/bin/chromium"
    for f in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
              "--disable-background-networking", "--disable-component-update", "--disable-sync",
              "--disable-dev-shm-usage", "--window-size=1700,1250",
              f"--user-data-dir={os.path.join(tmp, 'profile')}"):
        o.add_argument(f)
    service = Service("/usr/bin/chromedriver", env=dict(os.environ, TMPDIR=tmp))
    d = webdriver.Chrome(service=service, options=o)
    try:
        yield d
    finally:
        d.quit()
        shutil.rmtree(tmp, ignore_errors=True)


def run_states(a):
    out = os.path.join(a.out, "run_states.csv")
    subprocess.run([a.ballvision, "run", a.seq, "--calib", a.calib, "--lut", "builtin", "--out",
                    out], check=True, capture_output=True)
    with open(out, newline="") as f:
        return {int(r["index"]): r for r in csv.DictReader(f)}


def truth(a):
    with open(os.path.join(a.seq, "truth.csv"), newline="") as f:
        return {int(r["index"]): r for r in csv.DictReader(f)}


def go_to_frame(d, pos):
    d.execute_script("const s = document.getElementById('slider'); s.value = arguments[0];"
                     "s.dispatchEvent(new Event('input'));", pos)


def image_ready(d, cam):
    return d.execute_script(f"const i = document.getElementById('img-{cam}');"
                            "return i.complete && i.naturalWidth > 0 ? i.src : null;")


def top_view_checks(d, states):
    """The drawn ball against ballvision run's state, and the canvas pixel under it."""
    n = d.execute_script("return frames().length;")
    checked = 0
    for pos in (n // 4, n // 2, 3 * n // 4):
        go_to_frame(d, pos)
        idx = d.execute_script("return frames()[state.cur].index;")
        want = states[idx]
        if want["found"] != "1":
            continue
        xy = d.execute_script("return document.getElementById('topview').dataset.ballXy;")
        got = [float(v) for v in xy.split(",")] if xy else None
        ok = got is not None and abs(got[0] - float(want["x"])) < 1e-3 and \
            abs(got[1] - float(want["y"])) < 1e-3
        check(ok, f"top view, frame {idx}: ball drawn at {got} m, ballvision run says "
                  f"({want['x']}, {want['y']})")
        px = d.execute_script(
            "const v = window.studioView, p = v.toCanvas(...v.fromRobot(arguments[0], "
            "arguments[1])); const c = document.getElementById('topview').getContext('2d')"
            ".getImageData(Math.round(p[0]), Math.round(p[1]), 1, 1).data;"
            "return [p[0], p[1], c[0], c[1], c[2]];", float(want["x"]), float(want["y"]))
        check(px[2] > 200 and 80 < px[3] < 160 and px[4] < 60,
              f"top view, frame {idx}: canvas pixel at ({px[0]:.0f}, {px[1]:.0f}) is the ball's "
              f"orange (rgb {px[2]}, {px[3]}, {px[4]})")
        checked += 1
    check(checked >= 2, f"top view checked on {checked} frames with the ball")


def teach_check(a, d, url, truth_rows):
    """Clicks on the ball in the perspective image of a frame where it is fully visible."""
    n = d.execute_script("return frames().length;")
    for pos in range(n // 3, n):
        idx = d.execute_script("return frames()[arguments[0]].index;", pos)
        t = truth_rows.get(idx)
        if t and t["visible_persp"] == "1" and float(t["area_persp"] or 0) > 300:
            break
    else:
        return check(False, "a frame with the ball well visible in the perspective camera")
    go_to_frame(d, pos)
    before = wait_for(lambda: image_ready(d, "persp"), 20, "perspective image loaded")
    gen0 = d.execute_script("return state.gen;")
    u, v = float(t["cu_persp"]), float(t["cv_persp"])
    img = d.find_element(By.ID, "img-persp")
    w, h, nw, nh = d.execute_script("const i = arguments[0]; return [i.clientWidth, "
                                    "i.clientHeight, i.naturalWidth, i.naturalHeight];", img)
    ActionChains(d).move_to_element_with_offset(img, u * w / nw - w / 2,
                                                v * h / nh - h / 2).click().perform()
    report = wait_for(lambda: d.find_element(By.ID, "teach-report").text.startswith("taught")
                      and d.find_element(By.ID, "teach-report").text, 600, "teach report shown")
    check(bool(report) and "model: hue" in (report or ""), f"click taught: {report!r}")
    gen1 = d.execute_script("return state.gen;")
    check(gen1 == gen0 + 1, f"frames processed again with the taught table (gen {gen0} -> {gen1})")
    after = wait_for(lambda: image_ready(d, "persp") != before and image_ready(d, "persp"), 20,
                     "perspective image reloaded")
    if before and after:
        b0 = urllib.request.urlopen(before).read()
        b1 = urllib.request.urlopen(after).read()
        check(b0 != b1, "the classification drawn in the perspective image changed")
    lut = urllib.request.urlopen(url + "api/lut").read()
    check(len(lut) > 1000, f"the taught table can be saved ({len(lut)} bytes)")
    msg = d.execute_script("return document.getElementById('message').textContent;")
    check("taught" in msg and "model" in msg, f"page message after the teach: {msg[:80]!r}")


def sequence_mode(a):
    states, truth_rows = run_states(a), truth(a)
    studio, url = start_studio(a, a.seq, ("--lut", "builtin"))
    try:
        with browser() as d:
            d.get(url)
            wait_for(lambda: image_ready(d, "omni") and image_ready(d, "persp"), 60,
                     "both cameras' frames shown")
            label = d.find_element(By.ID, "frame-label").text
            check(label.startswith("frame "), f"frame label: {label!r}")
            d.save_screenshot(os.path.join(a.out, "studio_sequence.png"))
            top_view_checks(d, states)
            d.save_screenshot(os.path.join(a.out, "studio_topview.png"))
            teach_check(a, d, url, truth_rows)
            d.save_screenshot(os.path.join(a.out, "studio_taught.png"))
            d.find_element(By.ID, "open-path").send_keys(a.out)
            d.find_element(By.ID, "open").click()
            msg = wait_for(lambda: "not a captured sequence" in d.find_element(By.ID, "message").text
                           and d.find_element(By.ID, "message").text, 30, "bad folder message")
            check(bool(msg), f"a folder that is not a sequence: {msg!r}")
            d.save_screenshot(os.path.join(a.out, "studio_bad_folder.png"))
    finally:
        studio.kill()


def live_mode(a):
    studio, url = start_studio(a, a.live, ("--lut", a.live_lut) if a.live_lut else ())
    try:
        with browser() as d:
            d.get(url)
            got = wait_for(lambda: d.execute_script(
                "const l = state.data && state.data.live; return l && l.connected && "
                "l.states.filter((s) => s.found).length > 5 && l.status ? l.states.length : 0;"), 60,
                "live ball states and a status packet")
            check(bool(got), f"live: {got} ball states from the device on the page")
            wait_for(lambda: d.execute_script("return document.getElementById('topview').dataset"
                                              ".ballPx;"), 10, "live ball in the top view")
            rows = d.find_element(By.ID, "counters").text
            check("frames processed" in rows and "link connected" in rows,
                  "live status counters: " + rows.replace("\n", "; ")[:160])
            d.save_screenshot(os.path.join(a.out, "studio_live.png"))
            if a.live_lut:
                d.find_element(By.ID, "upload").click()
                msg = wait_for(lambda: "uploaded" in d.find_element(By.ID, "message").text and
                               d.find_element(By.ID, "message").text, 120, "upload acknowledged")
                check(bool(msg), f"live: the table uploaded from the page: {msg!r}")
                lut_id = wait_for(lambda: d.execute_script(
                    "const s = state.data.live.status; return s && s.lut_state === 0 && s.lut_id;"),
                    10, "status names the uploaded table")
                check(bool(lut_id), f"live: the device's status reports colour table id {lut_id}")
            d.find_element(By.ID, "grab").click()
            grabbed = wait_for(lambda: image_ready(d, "omni") and image_ready(d, "persp") and
                               d.execute_script("return state.data.sequence.dir;"), 90,
                               "a grabbed pair shown")
            check(bool(grabbed), f"live: grabbed one pair from the device and opened it: {grabbed}")
            n = d.execute_script("return frames().length;")
            check(n == 1, f"live: the grabbed sequence has {n} pair(s), 1 asked")
            d.save_screenshot(os.path.join(a.out, "studio_live_grab.png"))
            subprocess.run(a.live_end, shell=True)
            msg = wait_for(lambda: "ended" in d.find_element(By.ID, "message").text and
                           d.find_element(By.ID, "message").text, 30, "link-ended message")
            check(bool(msg), f"live: the device went away: {msg!r}")
            state = d.find_element(By.ID, "link-state").text
            check(state == "link down", f"live: link state shown as {state!r}")
            d.save_screenshot(os.path.join(a.out, "studio_link_down.png"))
    finally:
        studio.kill()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ballvision", required=True)
    ap.add_argument("--calib", required=True)
    ap.add_argument("--seq")
    ap.add_argument("--out", required=True)
    ap.add_argument("--live")
    ap.add_argument("--live-end", default="true")
    ap.add_argument("--live-lut", help="a colour table the page uploads to the live device")
    a = ap.parse_args()
    if a.seq and not os.path.isfile(os.path.join(a.seq, "truth.csv")):
        print(f"SKIP: {a.seq} (shared data) not found")
        return 77
    os.makedirs(a.out, exist_ok=True)
    a.calib, a.ballvision = os.path.abspath(a.calib), os.path.abspath(a.ballvision)
    if a.seq:
        sequence_mode(a)
    if a.live:
        live_mode(a)
    print(f"{'FAILED: ' + str(len(FAILED)) if FAILED else 'all checks passed'}; screenshots in "
          f"{a.out}")
    return 1 if FAILED else 0


if __name__ == "__main__":
    sys.exit(main())
