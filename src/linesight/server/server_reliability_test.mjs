// The base-station server under load, bad requests and signals (loopback only, bounded in count
// and time):
//
//   node server_reliability_test.mjs --linesight BIN [--clients 20] [--seconds 30] [--json FILE]
//
// 1. Bad requests answer 4xx with a JSON error and the server keeps serving: malformed JSON, wrong
//    types, an ROI outside the image, an oversize body (413), unknown paths, fault crops that are
//    not kept and path traversal (404), a wrong method (405 with Allow), a POST that is not JSON (415), a 100 kB URL (414), and
//    a request sent in half and left open.
// 2. Load: `--clients` concurrent clients for `--seconds`, a quarter on the event stream, a quarter
//    on the MJPEG stream, the rest on the API and the images, each at most `--rate` requests per
//    second (the server closes a connection after one idle second, so each request is a new
//    connection, and unpaced clients on a fast machine can run the loopback out of ephemeral
//    ports: some 28 000, each held 60 s in TIME_WAIT): no failed request, every stream
//    client receives at least 90 % of the frames (streams send the newest), RSS growth under 10 %
//    (from after a warm-up). Then a client
//    that opens the video and never reads it does not slow the pipeline (frames in 10 s with it
//    against 10 s without it, 5 s before and 5 s after).
// 3. With an access token: a POST without it or with a wrong one gets 401, with it 200.
// 4. SIGTERM, and SIGINT, with a half-sent request open: the server exits cleanly within 2 s.
// 5. A source that ends, a truncated video, and files that vanish mid-run: the status and the event
//    stream say so (running false; the error names the file), and the server keeps serving.
// Prints the figures; --json writes them.
import { spawnSync } from "node:child_process";
import fs from "node:fs";
import net from "node:net";
import os from "node:os";
import path from "node:path";
import process from "node:process";

import { startServe } from "./serve_process.mjs";

function arg(name, fallback) {
  const i = process.argv.indexOf(name);
  if (i < 0) {
    if (fallback === undefined) throw new Error(`usage: ${name} is required`);
    return fallback;
  }
  return process.argv[i + 1];
}
const linesight = arg("--linesight"), clients = Number(arg("--clients", "20"));
const seconds = Number(arg("--seconds", "30")), jsonPath = arg("--json", "");
const rate = Number(arg("--rate", "40"));  // requests per second of one API client
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
let failures = 0;
// A network error's message with its cause (fetch says only "fetch failed").
const why = (e) => `${e.message}${e.cause ? ` (${e.cause.code || e.cause.message})` : ""}`;
function check(ok, what) {
  console.log(`${ok ? "ok" : "FAIL"}: ${what}`);
  if (!ok) failures++;
}

// A still synthetic scene at a capped rate: the server, not the matcher, is under test.
const startServer = (extra = []) => startServe(linesight, ["--source", "synthetic:1", "--synthetic-speed", "0",
  "--max-fps", "2", "--threads", "1", ...extra]);
// Sends `signal` with a half-sent request open: the server must exit 0 within 2 s.
async function expectCleanExit(server, signal) {
  const open = await halfSent(server.port);
  const t = Date.now();
  server.child.kill(signal);
  const e = await Promise.race([server.exited, sleep(10000).then(() => null)]);
  const ms = e ? e.at - t : Infinity;
  check(e && e.code === 0 && ms <= 2000, `${signal} with a half-sent request open: exit ${e ? e.code : "none"} after ${ms} ms`);
  open.destroy();
  return ms;
}
function rssKb(pid) {
  const m = fs.readFileSync(`/proc/${pid}/status`, "utf8").match(/VmRSS:\s+(\d+)/);
  return Number(m[1]);
}
async function waitFirstFrame(base) {
  const end = Date.now() + 60000;
  while (Date.now() < end) {
    const s = await (await fetch(base + "/api/status")).json();
    if (s.frame >= 0) return;
    await sleep(200);
  }
  throw new Error("no frame in 60 s");
}
// A request written in part (headers promise a body that never comes), the socket left open.
function halfSent(port) {
  return new Promise((resolve, reject) => {
    const s = net.connect(port, "127.0.0.1", () => {
      s.write("POST /api/rois HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\nContent-Length: 100\r\n\r\n{\"ro");
      resolve(s);
    });
    s.on("error", () => {});
    s.setTimeout(20000, () => s.destroy());
    s.once("error", reject);
  });
}
// The status once the loop has stopped (or the last one seen when `ms` pass first).
async function statusOnceStopped(base, ms) {
  const end = Date.now() + ms;
  let s = {};
  while (Date.now() < end) {
    s = await (await fetch(base + "/api/status")).json();
    if (!s.running) break;
    await sleep(200);
  }
  return s;
}
// A client that asks for the video and never reads it (its socket buffers fill, then the server's
// writes to it block until their timeout).
function slowVideoClient(port) {
  return new Promise((resolve, reject) => {
    const s = net.connect(port, "127.0.0.1", () => {
      s.write("GET /api/stream.mjpeg?view=left HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n");
      s.pause();
      resolve(s);
    });
    s.on("error", () => {});
    s.once("error", reject);
  });
}
async function expectStatus(base, path, init, status, what) {
  const res = await fetch(base + path, init);
  const text = await res.text();
  let error = "";
  try { error = JSON.parse(text).error || ""; } catch { error = ""; }
  check(res.status === status && (status < 400 || error.length > 0),
    `${what}: ${res.status}${error ? ` "${error}"` : ""}${res.headers.get("allow") ? ` (Allow: ${res.headers.get("allow")})` : ""}`);
  return res;
}
const json = (body, extra = {}) => ({ method: "POST", headers: { "Content-Type": "application/json", ...extra }, body });

const figures = {};
const server = await startServer();
try {
  await waitFirstFrame(server.base);
  const b = server.base;
  // 1. Bad requests.
  const open = await halfSent(server.port);
  await expectStatus(b, "/api/rois", json("{\"rois\": [[1, 2"), 400, "malformed JSON");
  await expectStatus(b, "/api/rois", json("{\"rois\": \"all\"}"), 400, "wrong type");
  await expectStatus(b, "/api/rois", json("{\"rois\": [[700, 10, 100, 50]]}"), 400, "ROI outside the image");
  await expectStatus(b, "/api/alarm", json("{\"distance_m\": 1e9}"), 400, "alarm out of range");
  await expectStatus(b, "/api/rois", json("x".repeat(12 << 20)), 413, "12 MB body");
  await expectStatus(b, "/api/nothing", {}, 404, "unknown path");
  await expectStatus(b, "/../../etc/passwd", {}, 404, "path traversal");
  await expectStatus(b, "/%2e%2e/%2e%2e/etc/passwd", {}, 404, "encoded path traversal");
  await expectStatus(b, "/api/fault/abc.jpg", {}, 404, "a fault crop name that is not <id>.jpg");
  await expectStatus(b, "/api/fault/99999.jpg", {}, 404, "a fault that is not kept");
  await expectStatus(b, "/api/fault/..%2f..%2fetc%2fpasswd", {}, 404, "encoded path traversal under the fault crops");
  await expectStatus(b, "/api/fault/1.jpg", json("{}"), 405, "POST on a fault crop");
  await expectStatus(b, "/api/status", { method: "POST", headers: { "Content-Type": "application/json" }, body: "{}" }, 405, "POST on a GET route");
  await expectStatus(b, "/api/pause", {}, 405, "GET on a POST route");
  await expectStatus(b, "/api/rois", { method: "DELETE" }, 405, "DELETE");
  await expectStatus(b, "/api/pause", { method: "POST", headers: { "Content-Type": "text/plain" }, body: "" }, 415, "POST as text/plain (what another origin can send)");
  await expectStatus(b, "/api/status?x=" + "a".repeat(100000), {}, 414, "100 kB URL");
  const cors = await fetch(b + "/api/status", { headers: { Origin: "http://elsewhere.example" } });
  check(!cors.headers.get("access-control-allow-origin"), "no CORS header for another origin");
  await expectStatus(b, "/api/status", {}, 200, "still serving with a half-sent request open");

  // 2. Load.
  const paths = ["/api/status", "/api/result", "/api/frame/left.jpg", "/api/frame/disparity.jpg"];
  const warm = Date.now() + 3000;
  while (Date.now() < warm) {
    const t = Date.now();
    await Promise.all(paths.map((p) => fetch(b + p).then((r) => r.arrayBuffer())));
    await sleep(t + 1000 / rate - Date.now());
  }
  const rss0 = rssKb(server.child.pid);
  let ok = 0, failed = 0, maxMs = 0;
  const frame0 = (await (await fetch(b + "/api/status")).json()).frame;
  const end = Date.now() + seconds * 1000;
  const streamed = [];
  const worker = async (k) => {
    if (k % 4 < 2) {  // a stream client: counts what it receives until the end
      const marker = k % 4 === 0 ? "event: frame" : "--linesightframe";
      const controller = new AbortController();
      const stop = setTimeout(() => controller.abort(), end - Date.now());
      let count = 0, tail = "";
      try {
        const res = await fetch(b + (k % 4 === 0 ? "/api/events" : "/api/stream.mjpeg"), { signal: controller.signal });
        if (res.status !== 200) throw new Error(`status ${res.status}`);
        const decoder = new TextDecoder("latin1");
        for await (const chunk of res.body) {
          const text = tail + decoder.decode(chunk, { stream: true });
          count += text.split(marker).length - 1;
          tail = text.slice(-marker.length);
        }
        failed++;  // the server ended a stream before the client did
      } catch (e) {
        if (e.name === "AbortError") ok++; else failed++;
      } finally {
        clearTimeout(stop);
      }
      streamed.push({ kind: k % 4 === 0 ? "events" : "mjpeg", count });
      return;
    }
    for (let i = k; Date.now() < end; i++) {
      const t = Date.now();
      try {
        const res = await fetch(b + paths[i % paths.length] + (i % 8 === 1 ? "?after=-1" : ""));
        await res.arrayBuffer();
        if (res.status === 200) ok++; else failed++;
      } catch (e) {
        if (failed++ === 0) console.error(`first failed request: ${why(e)}`);
      }
      maxMs = Math.max(maxMs, Date.now() - t);
      await sleep(t + 1000 / rate - Date.now());
    }
  };
  await Promise.all(Array.from({ length: clients }, (_, k) => worker(k)));
  const frames = (await (await fetch(b + "/api/status")).json()).frame - frame0;
  const rss1 = rssKb(server.child.pid);
  const fewest = (kind) => Math.min(...streamed.filter((c) => c.kind === kind).map((c) => c.count));
  Object.assign(figures, { clients, seconds, rate_per_api_client: rate, requests: ok + failed, failed, max_latency_ms: maxMs,
    frames_published: frames, fewest_events_received: fewest("events"), fewest_mjpeg_parts_received: fewest("mjpeg"),
    rss_start_mb: rss0 / 1024, rss_end_mb: rss1 / 1024, rss_growth: rss1 / rss0 - 1 });
  check(failed === 0, `${clients} clients for ${seconds} s: ${ok + failed} requests and streams, ${failed} failed, slowest request ${maxMs} ms`);
  // Streams carry the newest frame (a writer that wakes after two publications sends the second
  // only), so a client under this load may miss one now and then, never most.
  check(fewest("events") >= 0.9 * frames && fewest("mjpeg") >= 0.9 * frames,
    `every stream client kept up: ${frames} frames published, fewest received ${fewest("events")} events, ${fewest("mjpeg")} MJPEG parts`);
  check(rss1 / rss0 - 1 < 0.10, `RSS ${(rss0 / 1024).toFixed(0)} -> ${(rss1 / 1024).toFixed(0)} MB (${(100 * (rss1 / rss0 - 1)).toFixed(1)} %)`);

  // A client that opens the video and never reads it: the pipeline keeps the rate it has without it.
  const framesIn = async (ms) => {
    const f0 = (await (await fetch(b + "/api/status")).json()).frame;
    await sleep(ms);
    return (await (await fetch(b + "/api/status")).json()).frame - f0;
  };
  // Without it for 5 s, with it for 10 s, without it for 5 s: a change of the machine's background
  // load during the test falls on both sides alike.
  let alone = await framesIn(5000);
  const slow = await slowVideoClient(server.port);
  const withSlow = await framesIn(10000);
  slow.destroy();
  alone += await framesIn(5000);
  Object.assign(figures, { frames_in_10s_alone: alone, frames_in_10s_with_a_client_that_never_reads: withSlow });
  check(withSlow >= 0.8 * alone && withSlow > 0,
    `a client that never reads its video does not slow the pipeline: ${withSlow} frames in 10 s with it, ${alone} without`);

  // 4. SIGTERM with half-sent requests open.
  figures.sigterm_exit_ms = await expectCleanExit(server, "SIGTERM");
  open.destroy();
} catch (e) {
  failures++;
  console.error(`FAIL: ${why(e)}\nserve's log:\n${server.log()}`);
} finally {
  server.child.kill("SIGKILL");
}

// 3. The access token, and SIGINT.
const secret = "s3cret-token";
const guarded = await startServer(["--token", secret]);
try {
  await waitFirstFrame(guarded.base);
  const g = guarded.base;
  await expectStatus(g, "/api/pause", json(""), 401, "POST without the token");
  await expectStatus(g, "/api/pause", json("", { Authorization: "Bearer wrong" }), 401, "POST with a wrong token");
  await expectStatus(g, "/api/pause", json("", { Authorization: `Bearer ${secret}` }), 200, "POST with the token");
  await expectStatus(g, "/api/status", {}, 200, "GET needs no token");
  figures.sigint_exit_ms = await expectCleanExit(guarded, "SIGINT");
} catch (e) {
  failures++;
  console.error(`FAIL: ${why(e)}\nserve's log:\n${guarded.log()}`);
} finally {
  guarded.child.kill("SIGKILL");
}
// 5. A source that ends, and a source whose files vanish.
const pairs = fs.mkdtempSync(path.join(os.tmpdir(), "linesight-reliability-"));
try {
  const render = spawnSync(linesight, ["render", "--sequence", "3", "--seed", "3", "--supersampling", "1", "--out", pairs],
    { encoding: "utf8" });
  if (render.status !== 0) throw new Error(`render failed: ${render.stderr}`);
  const images = ["--source", `images:${pairs}/left_*.png,${pairs}/right_*.png`, "--calib", `${pairs}/stereo.yml`, "--threads", "1"];
  const ends = await startServe(linesight, images);
  try {
    const events = await fetch(ends.base + "/api/events");
    const reader = events.body.getReader(), decoder = new TextDecoder();
    let text = "";
    const deadline = Date.now() + 60000;
    while (!/"running":false/.test(text) && Date.now() < deadline) text += decoder.decode((await reader.read()).value);
    await reader.cancel();
    const s = await (await fetch(ends.base + "/api/status")).json();
    check(s.running === false && s.error === "" && s.frame === 2 && /"running":false/.test(text),
      `a source that ends: status running ${s.running} after frame ${s.frame}, error "${s.error}", the event stream says so too`);
    await expectStatus(ends.base, "/api/result", {}, 200, "the last result is still served after the end");
  } finally {
    ends.child.kill("SIGKILL");
  }
  // A truncated video (12 frames announced, the right file cut at 60 %): the error names it.
  const video = spawnSync("/usr/bin/python3", ["-c", `
import cv2, glob, sys
d = sys.argv[1]
for side in ("left", "right"):
    images = [cv2.imread(f) for f in sorted(glob.glob(f"{d}/{side}_*.png"))]
    h, w = images[0].shape[:2]
    out = cv2.VideoWriter(f"{d}/{side}.avi", cv2.VideoWriter_fourcc(*"MJPG"), 10, (w, h))
    for i in range(12):
        out.write(images[i % len(images)])
    out.release()
data = open(f"{d}/right.avi", "rb").read()
open(f"{d}/right_cut.avi", "wb").write(data[: len(data) * 6 // 10])
`, pairs], { encoding: "utf8" });
  if (video.status !== 0) throw new Error(`writing the test videos failed (python3-opencv): ${video.stderr}`);
  const cut = await startServe(linesight, ["--source", `video:${pairs}/left.avi,${pairs}/right_cut.avi`,
    "--calib", `${pairs}/stereo.yml`, "--threads", "1"]);
  try {
    const s = await statusOnceStopped(cut.base, 60000);
    check(s.running === false && /right_cut\.avi' ended after \d+ of the 12 frames/.test(s.error),
      `a truncated video: running ${s.running}, error "${s.error}"`);
    await expectStatus(cut.base, "/api/status", {}, 200, "still serving after the truncated video");
  } finally {
    cut.child.kill("SIGKILL");
  }

  // The files vanish after the first frame (at a capped rate, so the second read comes later).
  const vanishing = await startServe(linesight, [...images, "--max-fps", "0.5"]);
  try {
    for (const f of fs.readdirSync(pairs)) if (/^(left|right)_000[12]\.png$/.test(f)) fs.rmSync(path.join(pairs, f));
    const s = await statusOnceStopped(vanishing.base, 30000);
    check(s.running === false && /left_0001\.png/.test(s.error),
      `files that vanish: running ${s.running}, error "${s.error}"`);
    await expectStatus(vanishing.base, "/api/status", {}, 200, "still serving after the source failed");
  } finally {
    vanishing.child.kill("SIGKILL");
  }
} catch (e) {
  failures++;
  console.error(`FAIL: ${why(e)}`);
} finally {
  fs.rmSync(pairs, { recursive: true, force: true });
}

if (jsonPath) fs.writeFileSync(jsonPath, JSON.stringify(figures, null, 2) + "\n");
console.log(failures ? `FAILED (${failures})` : "passed");
process.exit(failures ? 1 : 0);
