// `linesight serve` as a child process for the server's Node tests: started on a free port of
// 127.0.0.1, its address read from the line it prints on stdout.
import { spawn } from "node:child_process";

// Resolves to {child, base ("http://127.0.0.1:PORT"), port, exited (resolves to {code, signal, at}),
// log() (its stderr so far)}; rejects when serve exits or prints no address within 60 s.
export async function startServe(linesight, args) {
  const child = spawn(linesight, ["serve", "--port", "0", ...args], { stdio: ["ignore", "pipe", "pipe"] });
  let log = "";
  child.stderr.on("data", (d) => { log += d; });
  const exited = new Promise((r) => child.on("exit", (code, signal) => r({ code, signal, at: Date.now() })));
  const base = await new Promise((resolve, reject) => {
    let text = "";
    const timer = setTimeout(() => reject(new Error(`serve printed no address in 60 s:\n${log}`)), 60000);
    child.stdout.on("data", (d) => {
      text += d;
      const m = text.match(/serving (http:\/\/127\.0\.0\.1:\d+)\//);
      if (m) { clearTimeout(timer); resolve(m[1]); }
    });
    exited.then(({ code }) => { clearTimeout(timer); reject(new Error(`serve exited (${code}) before serving:\n${log}`)); });
  });
  return { child, base, port: Number(base.split(":")[2]), exited, log: () => log };
}
