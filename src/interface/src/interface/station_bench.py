"""Measures the web operator station against its targets, on a running `start.launch ui:=web`:

- page updates per second and camera frames per second in a real (headless Chromium) page: >= 10;
- the station node's CPU (share of one core) and memory (RSS) with no page, one page, and one page plus
  ten more WebSocket clients that read everything a page gets: <= 10 % of a core with one page;
- from a click on a menu button to the command on operator/command (wall clock, browser and ROS on this
  machine): < 100 ms;
- pages that connect and vanish (hundreds of times) and two that never read: memory before and after;
- a soak with one page open: RSS over time (does it grow?), and the simulation's real-time factor in
  every phase (does a page slow it down?).

It only reads and clicks harmless things (the Acknowledge button, which the supervisor ignores while there
is no emergency). Results are printed as a table and written as JSON (--out)."""
import argparse
import asyncio
import json
import os
import statistics
import sys
import time

CLICK_SAMPLES = 20


class Process:
    """CPU and RSS of one process from /proc."""

    def __init__(self, pid):
        self.pid = pid
        self.ticks = os.sysconf("SC_CLK_TCK")

    def cpu_seconds(self):
        with open("/proc/%d/stat" % self.pid) as stream:
            fields = stream.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / self.ticks   # utime + stime

    def rss_mb(self):
        with open("/proc/%d/status" % self.pid) as stream:
            for line in stream:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024.0
        return float("nan")


class Phase:
    """CPU share, RSS and the simulation's real-time factor over one measured interval."""

    def __init__(self, name, process, sim_time):
        self.name, self.process, self.sim_time = name, process, sim_time
        self.wall0, self.cpu0, self.sim0 = time.monotonic(), process.cpu_seconds(), sim_time()
        self.rss0 = process.rss_mb()
        self.extra = {}

    def end(self):
        wall = time.monotonic() - self.wall0
        return dict({"phase": self.name, "wall_s": round(wall, 1),
                     "cpu_percent_of_one_core": round(100.0 * (self.process.cpu_seconds() - self.cpu0) / wall, 1),
                     "rss_mb_start": round(self.rss0, 1), "rss_mb_end": round(self.process.rss_mb(), 1),
                     "sim_real_time_factor": round((self.sim_time() - self.sim0) / wall, 2)}, **self.extra)


async def _websocket_clients(url, count, seconds, stop_reading=0):
    """``count`` clients that read everything for ``seconds``; ``stop_reading`` of them never read at all.
    Returns messages per second received by each reading client."""
    import aiohttp
    base = url.rstrip("/")
    origin = base
    counts = [0] * count

    async def client(index, session):
        async with session.ws_connect(base + "/ws", headers={"Origin": origin}, max_msg_size=0) as ws:
            if index < stop_reading:
                ws._response.connection.transport.pause_reading()
                await asyncio.sleep(seconds)
                return
            end = time.monotonic() + seconds
            while time.monotonic() < end:
                try:
                    await asyncio.wait_for(ws.receive(), max(0.01, end - time.monotonic()))
                except asyncio.TimeoutError:
                    break
                counts[index] += 1
    async with aiohttp.ClientSession() as session:
        await asyncio.gather(*(client(i, session) for i in range(count)), return_exceptions=True)
    return [c / seconds for c in counts[stop_reading:]]


async def _churn(url, cycles):
    """Pages that open the WebSocket, take a few messages and vanish (closed, or the socket just dropped)."""
    import aiohttp
    base = url.rstrip("/")
    async with aiohttp.ClientSession() as session:
        for cycle in range(cycles):
            ws = await session.ws_connect(base + "/ws", headers={"Origin": base}, max_msg_size=0)
            for _ in range(3):
                await ws.receive()
            if cycle % 2:
                await ws.close()
            else:
                ws._response.connection.transport.abort()   # as a browser tab that crashed


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--url", default=None, help="station URL (default: the parameter /station/url)")
    parser.add_argument("--phase-s", type=float, default=30.0, help="length of each measured phase [s]")
    parser.add_argument("--soak-s", type=float, default=300.0, help="soak with one page open [s]")
    parser.add_argument("--clients", type=int, default=10, help="extra WebSocket clients in the crowd phase")
    parser.add_argument("--churn", type=int, default=300, help="pages that connect and vanish")
    parser.add_argument("--fly", action="store_true",
                        help="click Start and Landing Mode first, so the measurement covers a landing mission")
    parser.add_argument("--screenshot", default=None, help="save a screenshot of the page here (PNG)")
    parser.add_argument("--out", default=None, help="write the results as JSON here")
    args = parser.parse_args(argv)

    import rosgraph
    import rospy
    from std_msgs.msg import String
    from xmlrpc.client import ServerProxy
    from .station_browser import Browser

    rospy.init_node("station_bench", anonymous=True, disable_signals=True)
    url = args.url or rospy.get_param("/station/url")
    node_uri = rosgraph.Master("/station_bench").lookupNode("/station")
    process = Process(ServerProxy(node_uri).getPid("/station_bench")[2])
    commands = []
    rospy.Subscriber("/operator/command", String, lambda m: commands.append((time.time(), m.data)), queue_size=100)
    results = []

    def measure(name, seconds, during=None):
        phase = Phase(name, process, rospy.get_time)
        extra = during() if during else time.sleep(seconds)
        if isinstance(extra, dict):
            phase.extra.update(extra)
        results.append(phase.end())
        print(json.dumps(results[-1]), flush=True)

    measure("no page", args.phase_s)
    browser = Browser()
    driver = browser.driver
    try:
        driver.get(url)
        deadline = time.monotonic() + 60
        while not driver.execute_script("return window.stationStats.lastRates"):
            if time.monotonic() > deadline:
                raise SystemExit("the page did not report its rates within 60 s: is the station running at %s?" % url)
            time.sleep(0.2)
        if args.fly:
            for screen, command in (("start", "start"), ("flight_management", "landing")):
                deadline = time.monotonic() + 30
                while driver.execute_script("return window.stationStats.lastState.screen") != screen:
                    if time.monotonic() > deadline:
                        raise SystemExit("the page did not show the %s menu within 30 s" % screen)
                    time.sleep(0.1)
                driver.execute_script("document.querySelector('#screen-%s button[data-command=%s]').click()"
                                      % (screen, command))

        def page_rates():
            rates = []
            end = time.monotonic() + args.phase_s
            while time.monotonic() < end:
                time.sleep(2.0)
                rates.append(driver.execute_script("return window.stationStats.lastRates"))
            return {"page_updates_per_s": round(statistics.mean(r["state"] for r in rates), 1),
                    "page_updates_per_s_min": round(min(r["state"] for r in rates), 1),
                    "camera_fps": round(statistics.mean(r["frames"] for r in rates), 1),
                    "camera_fps_min": round(min(r["frames"] for r in rates), 1)}
        measure("1 page (Chromium)", args.phase_s, page_rates)

        latencies = []
        for _ in range(CLICK_SAMPLES):
            before = len(commands)
            clicked = driver.execute_script("const t = Date.now(); document.getElementById('ack').click(); return t;")
            deadline = time.monotonic() + 5
            while len(commands) == before and time.monotonic() < deadline:
                time.sleep(0.001)
            if len(commands) > before:
                latencies.append(commands[before][0] * 1000.0 - clicked)
            time.sleep(0.2)
        click = {"clicks": len(latencies), "median_ms": round(statistics.median(latencies), 1),
                 "max_ms": round(max(latencies), 1)}
        print(json.dumps({"click_to_operator_command": click}), flush=True)

        def crowd():
            rates = asyncio.run(_websocket_clients(url, args.clients, args.phase_s))
            page = driver.execute_script("return window.stationStats.lastRates")
            return {"client_messages_per_s_min": round(min(rates), 1), "page_updates_per_s": round(page["state"], 1)}
        measure("1 page + %d WebSocket clients" % args.clients, args.phase_s, crowd)

        def churn():
            asyncio.run(_churn(url, args.churn))
            asyncio.run(_websocket_clients(url, 2, 10.0, stop_reading=2))
            return {"pages_that_vanished": args.churn, "clients_that_never_read": 2}
        measure("churn", 0.0, churn)

        samples = []

        def soak():
            end = time.monotonic() + args.soak_s
            while time.monotonic() < end:
                time.sleep(min(30.0, max(0.0, end - time.monotonic())))
                samples.append([round(args.soak_s - (end - time.monotonic())), round(process.rss_mb(), 1)])
            page = driver.execute_script("return window.stationStats.lastRates")
            return {"rss_mb_over_time": samples, "page_updates_per_s": round(page["state"], 1)}
        measure("soak, 1 page", args.soak_s, soak)
        if args.screenshot:
            driver.save_screenshot(args.screenshot)
    finally:
        browser.quit()
    summary = {"url": url, "phases": results, "click_to_operator_command": click}
    if args.out:
        with open(args.out, "w") as stream:
            json.dump(summary, stream, indent=1)
    print("\n| phase | wall [s] | station CPU [% of a core] | RSS start -> end [MB] | sim RTF | page updates/s |")
    print("|---|---|---|---|---|---|")
    for r in results:
        print("| %s | %s | %s | %s -> %s | %s | %s |" % (r["phase"], r["wall_s"], r["cpu_percent_of_one_core"],
                                                       r["rss_mb_start"], r["rss_mb_end"], r["sim_real_time_factor"],
                                                       r.get("page_updates_per_s", "-")))
    print("click -> operator/command: median %.1f ms, max %.1f ms over %d clicks" % (
        click["median_ms"], click["max_ms"], click["clicks"]))
    rospy.signal_shutdown("done")
    return 0


if __name__ == "__main__":
    sys.exit(main())
