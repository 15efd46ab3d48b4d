// The base-station page's frame rate against the pipeline's, measured in Debian's chromium:
// starts `linesight serve` with the given arguments on loopback, opens the page, and over
// --seconds counts the frames the page shows (every one it receives by server-sent events) and
// the frames the station publishes. Prints both rates; --json writes them, --screenshot FILE saves
// the page at the end.
//
//   node scripts/measure_page_rate.mjs --linesight build/apps/linesight --seconds 30 -- \
//     --source pair:out/left.png,out/right.png --calib out/stereo.yml
import fs from "node:fs";
import os from "node:os";
import path from "node:path";
import process from "node:process";

import { startServe } from "../src/linesight/server/serve_process.mjs";

function arg(name, fallback) {
  const i = process.argv.indexOf(name);
  if (i < 0 || process.argv.indexOf("--") < i) {
    if (fallback === undefined) throw new Error(`usage: ${name} is required`);
    return fallback;
  }
  return process.argv[i + 1];
}
const linesight = arg("--linesight"), seconds = Number(arg("--seconds", "30")), jsonPath = arg("--json", "");
const screenshot = arg("--screenshot", "");
const serveArgs = process.argv.slice(process.argv.indexOf("--") + 1);
const { chromium } = await import("playwright-core");
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

const server = await startServe(linesight, serveArgs);
const userDataDir = fs.mkdtempSync(path.join(os.tmpdir(), "linesight-page-rate-"));
const browser = await chromium.launchPersistentContext(userDataDir, {
  executablePath: "/usr/bin/chromium", headless: true, viewport: { width: 1400, height: 1000 },
  args: ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
    "--disable-component-update", "--disable-sync", "--no-first-run"],
});
try {
  const page = browser.pages()[0] || (await browser.newPage());
  await page.goto(server.base + "/");
  const shown = () => page.evaluate(() => Number(document.body.dataset.framesShown || 0));
  const status = async () => (await fetch(server.base + "/api/status")).json();
  const end = Date.now() + 120000;
  while ((await shown()) < 3 && Date.now() < end) await sleep(200);  // warm-up
  const p0 = await shown(), s0 = await status(), t0 = Date.now();
  await sleep(seconds * 1000);
  const p1 = await shown(), s1 = await status(), t1 = Date.now();
  const figures = {
    seconds: (t1 - t0) / 1000,
    page_frames: p1 - p0,
    pipeline_frames: s1.frame - s0.frame,
    page_fps: (p1 - p0) / ((t1 - t0) / 1000),
    pipeline_fps: (s1.frame - s0.frame) / ((t1 - t0) / 1000),
    stages_ms: s1.stages_ms,
    latency_ms: s1.latency_ms,
  };
  console.log(JSON.stringify(figures, null, 2));
  if (screenshot) await page.screenshot({ path: screenshot, fullPage: true });
  if (jsonPath) fs.writeFileSync(jsonPath, JSON.stringify(figures, null, 2) + "\n");
} finally {
  await browser.close();
  fs.rmSync(userDataDir, { recursive: true, force: true });
  server.child.kill("SIGTERM");
  await server.exited;
}
