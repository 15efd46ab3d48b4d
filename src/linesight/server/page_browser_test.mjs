// The base-station page in a real browser: Debian's chromium, driven by playwright-core, against
// `linesight serve` on the moving synthetic sequence (loopback only, a bounded run).
//
//   node page_browser_test.mjs --linesight BIN --out DIR
//
// Checks: the page loads without console errors; results arrive pushed (server-sent events) and
// the page shows every frame the pipeline publishes (its frame rate is the pipeline's); the badge
// says LIVE, the stage timings and the calibration's health are shown; the faults on the line are
// listed (or the list says there is none) with the conductor's inspection; the images and the table
// update; the record switch writes the raw pairs and a result line per frame; pause holds the
// frame and resume moves on; the automatic-finding switch turns finding off and on; a box
// dragged on the nearest obstacle ranges it within 2 % of its true straight distance; when the
// run ends, the nearest obstacle shown on the line is the scene's nearest, of its type, within
// 2 % of its true distance along the line, and nothing else is listed that is not an obstacle of
// the scene. Screenshots go to DIR. Exit 77 (skipped) without chromium or playwright-core, unless
// CI=true, where both must be present.
import { spawnSync } from "node:child_process";
import fs from "node:fs";
import path from "node:path";
import process from "node:process";

import { startServe } from "./serve_process.mjs";

const CHROMIUM = "/usr/bin/chromium";
const SEED = 3, START_M = 2.5, FRAMES = 30;
const inCi = process.env.CI === "true";

function arg(name) {
  const i = process.argv.indexOf(name);
  if (i < 0 || i + 1 >= process.argv.length) throw new Error(`usage: ${name} is required`);
  return process.argv[i + 1];
}
function skip(why) {
  if (inCi) { console.error(`FAIL: ${why} (CI=true needs it: scripts/install-deps.sh installs it)`); process.exit(1); }
  console.log(`SKIPPED: ${why}`); process.exit(77);
}
function check(ok, what) {
  if (!ok) throw new Error(`check failed: ${what}`);
  console.log(`ok: ${what}`);
}
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
async function until(what, fn, timeoutMs) {
  const end = Date.now() + timeoutMs;
  for (;;) {
    const v = await fn();
    if (v) return v;
    if (Date.now() > end) throw new Error(`timed out after ${timeoutMs / 1000} s waiting for ${what}`);
    await sleep(100);
  }
}

const linesight = arg("--linesight"), out = arg("--out");
if (!fs.existsSync(CHROMIUM)) skip(`${CHROMIUM} not found (Debian package chromium)`);
let chromium;
try {
  ({ chromium } = await import("playwright-core"));
} catch (e) {
  skip(`playwright-core not installed (npm ci in the repository root): ${e.message}`);
}
fs.rmSync(out, { recursive: true, force: true });
fs.mkdirSync(out, { recursive: true });

// The truth of every frame: the same sequence rendered offline.
const truthDir = path.join(out, "truth");
const render = spawnSync(linesight, ["render", "--sequence", String(FRAMES), "--seed", String(SEED),
  "--start", String(START_M), "--supersampling", "1", "--out", truthDir], { encoding: "utf8" });
if (render.status !== 0) throw new Error(`render failed: ${render.stderr}`);
const truth = fs.readFileSync(path.join(truthDir, "truth.jsonl"), "utf8").trim().split("\n").map((l) => JSON.parse(l));

const recordDir = path.join(out, "recordings");
const server = await startServe(linesight, ["--source", `synthetic:${SEED}`, "--synthetic-start", String(START_M),
  "--frames", String(FRAMES), "--threads", "1", "--record-dir", recordDir, "--health-every", "10"]);
const base = server.base;
const api = async (p) => (await fetch(base + p)).json();

const userDataDir = fs.mkdtempSync(path.join(out, "profile-"));
const browser = await chromium.launchPersistentContext(userDataDir, {
  executablePath: CHROMIUM, headless: true, viewport: { width: 1400, height: 1000 },
  args: ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
    "--disable-component-update", "--disable-sync", "--no-first-run"],
});
let failed = false;
try {
  const page = browser.pages()[0] || (await browser.newPage());
  const consoleErrors = [];
  page.on("console", (m) => { if (m.type() === "error") consoleErrors.push(m.text()); });
  page.on("pageerror", (e) => consoleErrors.push(String(e)));
  await page.goto(base + "/");
  check((await page.title()) === "linesight base station", "the page loads");

  // Images and the table update.
  await until("the first frame on the page", () => page.evaluate(() =>
    document.getElementById("left").naturalWidth === 752 && document.getElementById("disparity").naturalWidth === 752), 60000);
  const frameShown = () => page.evaluate(() => Number((document.getElementById("status").textContent.match(/frame (\d+)/) || [])[1]));
  const f0 = await frameShown();
  const src0 = await page.evaluate(() => document.getElementById("left").src);
  await until("a newer frame", async () => (await frameShown()) > f0 &&
    (await page.evaluate(() => document.getElementById("left").src)) !== src0, 30000);
  check(true, `the images and the status update (frame ${f0} -> ${await frameShown()})`);
  await until("an obstacle in the line table", () => page.evaluate(() =>
    document.querySelectorAll("#line-tracks tr td:nth-child(2)").length > 0 &&
    !document.getElementById("line-tracks").textContent.includes("nothing")), 60000);
  check(true, "the line table lists an obstacle");
  check((await page.textContent("#badge")) === "LIVE", "the badge says LIVE");
  const timing = await page.textContent("#timing");
  check(/match \d+ · range \d+ · inspect \d+ · encode \d+ ms · latency \d+ ms/.test(timing), `stage timings shown ("${timing}")`);
  const faultList = await page.evaluate(() => ({ rows: document.querySelectorAll("#faults tr").length,
    text: document.getElementById("faults").textContent, inspection: document.getElementById("inspection").textContent }));
  check(faultList.rows > 0 && (faultList.text.includes("no fault seen on the line") || /#\d+/.test(faultList.text)) &&
    /^conductor (inspected|not inspected)/.test(faultList.inspection),
    `the faults on the line are listed ("${faultList.text.slice(0, 60)}"; "${faultList.inspection}")`);
  const health = await page.textContent("#health");
  check(/^health: good · row offset median 0\.\d\d px/.test(health), `the calibration's health is shown ("${health}")`);

  // The page shows every frame the pipeline publishes (pushed, none skipped).
  const counted = async () => ({ page: await page.evaluate(() => Number(document.body.dataset.framesShown || 0)),
    server: (await api("/api/status")).frame });
  const c0 = await counted();
  await until("five more frames", async () => (await counted()).server >= c0.server + 5, 60000);
  await sleep(300);
  const c1 = await counted();
  const pageFrames = c1.page - c0.page, serverFrames = c1.server - c0.server;
  check(pageFrames >= 0.9 * serverFrames, `the page showed ${pageFrames} of the pipeline's ${serverFrames} frames`);
  await page.screenshot({ path: path.join(out, "page-running.png"), fullPage: true });

  // The record switch.
  await page.click("#record");
  const rec = await until("a recording with 2 frames", async () => {
    const r = (await api("/api/status")).recording;
    return r.on && r.frames >= 2 ? r : null;
  }, 30000);
  await page.click("#record");
  const stopped = await until("the recording stopped", async () => {
    const r = (await api("/api/status")).recording;
    return !r.on ? r : null;
  }, 10000);
  const pngs = (side) => fs.readdirSync(path.join(rec.dir, side)).filter((f) => f.endsWith(".png")).length;
  const lines = fs.readFileSync(path.join(rec.dir, "results.jsonl"), "utf8").trim().split("\n").length;
  check(stopped.frames >= 2 && pngs("left") === stopped.frames && pngs("right") === stopped.frames && lines === stopped.frames &&
    fs.existsSync(path.join(rec.dir, "stereo.yml")), `the record switch wrote ${stopped.frames} pairs and result lines to ${rec.dir}`);

  // Pause holds the frame; resume moves on.
  await page.click("#pause");
  await until("the pause", async () => (await api("/api/status")).paused === true, 5000);
  // A frame already being ranged is still published (on a loaded machine that can take longer than
  // the last frame's processing time), so the frame number is read until it stays put for a frame
  // period; then nothing may move. Without the pause it never stays put.
  const perFrameMs = Math.max(500, 2 * (await api("/api/status")).process_ms);
  let held = (await api("/api/status")).frame;
  for (const settleBy = Date.now() + 15000; Date.now() < settleBy; ) {
    await sleep(perFrameMs);
    const frame = (await api("/api/status")).frame;
    if (frame === held) break;
    held = frame;
  }
  await sleep(perFrameMs);
  const after = (await api("/api/status")).frame, button = await page.textContent("#pause");
  check(after === held && button === "resume", `pause holds frame ${held} (then ${after}; button "${button}")`);
  await page.click("#pause");
  await until("frames after resume", async () => (await api("/api/status")).frame > held, 30000);
  check(true, "resume moves on");

  // The automatic-finding switch.
  await page.uncheck("#auto");
  await until("auto off", async () => (await api("/api/status")).auto === false, 5000);
  check(true, "the switch turns automatic finding off");
  await page.check("#auto");
  await until("auto on", async () => (await api("/api/status")).auto === true, 5000);
  check(true, "the switch turns automatic finding on");

  // A drag on the nearest obstacle ranges it.
  const now = await api("/api/status");
  const nearestTruth = (f) => truth[f].obstacles.reduce((a, b) => (b.arc_distance_m < a.arc_distance_m ? b : a));
  const target = nearestTruth(Math.min(now.frame + 5, FRAMES - 1));
  const [bx, by, bw, bh] = target.box, grow = 8;
  const box = await page.locator("#overlay").boundingBox();
  const s = box.width / 752;
  await page.mouse.move(box.x + (bx - grow) * s, box.y + (by - grow) * s);
  await page.mouse.down();
  await page.mouse.move(box.x + (bx + bw + grow) * s, box.y + (by + bh + grow) * s, { steps: 5 });
  await page.mouse.up();
  await until("the dragged region in the status", async () => (await api("/api/status")).rois.length === 1, 5000);
  const ranged = await until("the dragged region ranged", async () => {
    const r = await api("/api/result");
    const t = r.tracks.find((k) => k.key === "roi:0" || String(k.key).startsWith("roi"));
    return t && t.updates >= 2 ? { t, frame: r.frame } : null;
  }, 60000);
  const want = truth[ranged.frame].obstacles.find((o) => o.id === target.id).distance_m;
  const err = (ranged.t.last_measurement_m - want) / want;
  check(Math.abs(err) <= 0.02, `the dragged ${target.type} is ranged ${ranged.t.last_measurement_m.toFixed(3)} m for ` +
    `${want.toFixed(3)} m (${(100 * err).toFixed(2)} %)`);
  await page.screenshot({ path: path.join(out, "page-region.png"), fullPage: true });
  await page.click("#clear");

  // The end of the run: what the page shows against the truth of its last frame.
  // On a loaded machine a frame can take seconds, so the run may take minutes to end: the wait
  // fails only when the pipeline stops moving (no new frame for 60 s) while still running.
  for (let seen = -1, stallEnd = 0; ; await sleep(200)) {
    const st = await api("/api/status");
    if (st.running === false) break;
    if (st.frame !== seen) { seen = st.frame; stallEnd = Date.now() + 60000; }
    if (Date.now() > stallEnd) throw new Error(`the run stalled at frame ${seen} (no new frame for 60 s)`);
  }
  await sleep(1500);  // the page's next event
  const badge = await page.textContent("#badge");
  check(badge === "SOURCE ENDED", `the badge says the source ended ("${badge}")`);
  const last = await api("/api/result");
  const first = nearestTruth(last.frame);
  const shown = await page.textContent("#nearest");
  const m = shown.match(/(damper|clamp|insulator|spacer|unknown) (\d+\.\d+) m/);
  check(m !== null, `the nearest obstacle is shown ("${shown}")`);
  check(m[1] === first.type, `its type is the scene's nearest (${first.type})`);
  const arcErr = (Number(m[2]) - first.arc_distance_m) / first.arc_distance_m;
  check(Math.abs(arcErr) <= 0.02, `along the line ${m[2]} m for ${first.arc_distance_m.toFixed(3)} m (${(100 * arcErr).toFixed(2)} %)`);
  for (const t of last.line.tracks) {
    const [x, y, w, h] = t.box;
    const hit = truth[last.frame].obstacles.some((o) => x < o.box[0] + o.box[2] && o.box[0] < x + w && y < o.box[1] + o.box[3] && o.box[1] < y + h);
    check(hit, `track #${t.id} (${t.type} at ${t.arc_m.toFixed(2)} m) is an obstacle of the scene`);
  }
  await page.screenshot({ path: path.join(out, "page-end.png"), fullPage: true });
  check(consoleErrors.length === 0, `no console errors${consoleErrors.length ? ": " + consoleErrors.join(" | ") : ""}`);
} catch (e) {
  failed = true;
  console.error(`FAIL: ${e.message}\nserve's log:\n${server.log()}`);
} finally {
  await browser.close();
  fs.rmSync(userDataDir, { recursive: true, force: true });
  server.child.kill("SIGTERM");
}
const exitCode = (await server.exited).code;
if (exitCode !== 0 && !failed) { console.error(`FAIL: serve exited with ${exitCode}`); failed = true; }
console.log(failed ? "FAILED" : `passed; screenshots in ${out}`);
process.exit(failed ? 1 : 0);
