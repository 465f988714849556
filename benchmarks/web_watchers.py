"""What the web view costs the server, by how many browsers watch it.

A realtime `franka-sim serve --web 8080` with a pylibfranka client (its own process) running a
joint-position motion in each phase (joint 1 swinging 0.3 rad and back every 4 s, the arm
moving throughout, `--seconds` long), watched by 0, 1 and 3 headless chromium windows (Debian's chromium and chromedriver,
through selenium; each renders the page with SwiftShader on the CPU, so on a small machine the
browsers compete with the server for the cores). Prints per phase the server's CPU % of one
core over the motion, the cycle thread's and the view's drawing thread's (fsim-web) shares of
it (viser's own thread, which sends the frames, is in the rest), the lowest success rate the
robot reported during the motion, and the server's RSS; first without --web, for a baseline.
Figures, not asserts (docs/viewing.md keeps a run's).

python benchmarks/web_watchers.py [--seconds 10] [--watchers 0,1,3]
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import time

from _common import Load, cpu_seconds, memory_mib, start_server, thread_cpu_seconds

HOST = "127.0.0.206"
PORT = 8080

CLIENT = r'''
import json, math, sys
import numpy as np
import pylibfranka

robot = pylibfranka.Robot(sys.argv[1], pylibfranka.RealtimeConfig.kIgnore)
print("ready", flush=True)
for line in sys.stdin:
    seconds = 4.0 * max(1, round(float(line) / 4.0))  # whole swings: it ends at rest
    control = robot.start_joint_position_control(pylibfranka.ControllerMode.JointImpedance)
    state, _ = control.readOnce()
    q0, t, lowest = np.array(state.q_d), 0.0, 1.0
    while True:
        state, period = control.readOnce()
        t += period.to_sec()
        q = q0.copy()
        q[0] += 0.3 * 0.5 * (1 - math.cos(2 * math.pi * min(t, seconds) / 4.0))
        out = pylibfranka.JointPositions(q.tolist())
        out.motion_finished = t >= seconds
        control.writeOnce(out)
        if t > 0.1:
            lowest = min(lowest, state.control_command_success_rate)
        if out.motion_finished:
            break
    print(json.dumps({"min_rate": lowest}), flush=True)
'''


def browsers(n: int, url: str) -> list:
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    opened = []
    for _ in range(n):
        options = Options()
        for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage",
                    "--window-size=1280,800", "--use-gl=angle", "--use-angle=swiftshader",
                    "--enable-unsafe-swiftshader"):
            options.add_argument(arg)
        browser = webdriver.Chrome(service=Service(shutil.which("chromedriver")),
                                   options=options)
        browser.get(url)
        opened.append(browser)
    return opened


def phase(server, client, watchers: int, seconds: float, web: bool) -> dict:
    opened = browsers(watchers, f"http://{HOST}:{PORT}/") if watchers else []
    try:
        if watchers:
            server.wait_for_log(f"({watchers} watching)", 60)
            time.sleep(2.0)  # the page's first scene has gone out
        threads0, cpu0, t0 = thread_cpu_seconds(server.pid), cpu_seconds(server.pid), \
            time.perf_counter()
        load = Load(exclude={server.pid, client.pid})
        client.stdin.write(f"{seconds}\n")
        client.stdin.flush()
        result = json.loads(client.stdout.readline())
        wall = time.perf_counter() - t0
        cpu = 100 * (cpu_seconds(server.pid) - cpu0) / wall
        threads = thread_cpu_seconds(server.pid)
        web_cpu = 100 * (threads.get("fsim-web", 0) - threads0.get("fsim-web", 0)) / wall
        cycle_cpu = 100 * (threads.get("fsim-cycle", 0) - threads0.get("fsim-cycle", 0)) / wall
        return {"web": web, "watchers": watchers, "cpu": cpu, "web_thread": web_cpu,
                "cycle_thread": cycle_cpu,
                "min_rate": result["min_rate"], "rss": memory_mib(server.pid)[0],
                "others": "others %.0f %% of a core, CPU pressure %.0f %%" % load.stop()}
    finally:
        for browser in opened:
            browser.quit()


def run(args) -> list[dict]:
    rows = []
    for web in (False, True):
        flags = ("--web", str(PORT)) if web else ()
        server = start_server(HOST, None, *flags)
        client = subprocess.Popen([sys.executable, "-c", CLIENT, HOST], text=True,
                                  stdin=subprocess.PIPE, stdout=subprocess.PIPE)
        try:
            assert client.stdout.readline().strip() == "ready"
            for watchers in (args.watchers if web else [0]):
                rows.append(phase(server, client, watchers, args.seconds, web))
        finally:
            client.stdin.close()
            client.wait(30)
            server.stop()
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--watchers", type=lambda s: [int(v) for v in s.split(",")],
                        default=[0, 1, 3])
    args = parser.parse_args()
    if shutil.which("chromium") is None or shutil.which("chromedriver") is None:
        sys.exit("needs Debian's chromium and chromium-driver (apt-get install chromium "
                 "chromium-driver)")
    print(f"{'view':>6} {'watchers':>8} {'server CPU %':>12} {'cycle thr. %':>12} "
          f"{'fsim-web %':>10} {'min success':>11} {'RSS MiB':>8}  rest of the machine")
    for row in run(args):
        print(f"{'--web' if row['web'] else 'off':>6} {row['watchers']:>8} {row['cpu']:>12.1f} "
              f"{row['cycle_thread']:>12.1f} {row['web_thread']:>10.1f} "
              f"{row['min_rate']:>11.3f} {row['rss']:>8.1f}  {row['others']}")


if __name__ == "__main__":
    main()
