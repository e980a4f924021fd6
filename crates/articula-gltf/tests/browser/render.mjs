// Serves this folder and the .glb on localhost, opens page.html in headless Chromium
// (playwright-core driving the system's browser, never one it downloads), plays the
// animation to the times given, and for each: a screenshot, the node's world position as
// three.js computed it, its projected pixel, and the share of non-background pixels.
// Usage: node render.mjs FILE.glb NODE "ex,ey,ez" "tx,ty,tz" OUT_PREFIX t1 t2 ...
// Prints one JSON object. CHROMIUM names the browser (default /usr/bin/chromium).
import { createServer } from "node:http";
import { readFileSync, existsSync } from "node:fs";
import { join, dirname, extname } from "node:path";
import { fileURLToPath } from "node:url";
import { chromium } from "playwright-core";

const here = dirname(fileURLToPath(import.meta.url));
const [file, node, eye, target, out, ...times] = process.argv.slice(2);
const types = { ".html": "text/html", ".js": "text/javascript", ".glb": "model/gltf-binary" };
const server = createServer((req, res) => {
  const url = new URL(req.url, "http://localhost");
  const path = url.pathname === "/model.glb" ? file : join(here, decodeURIComponent(url.pathname));
  if (!path.startsWith(here) && path !== file) { res.writeHead(403); res.end(); return; }
  if (!existsSync(path)) { res.writeHead(404); res.end(); return; }
  res.writeHead(200, { "content-type": types[extname(path)] ?? "application/octet-stream" });
  res.end(readFileSync(path));
});
await new Promise((r) => server.listen(0, "127.0.0.1", r));
const port = server.address().port;
const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM ?? "/usr/bin/chromium",
  headless: true,
  args: ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--use-angle=swiftshader", "--enable-unsafe-swiftshader"],
  // playwright gives the browser a fresh temporary profile (its --user-data-dir) and deletes it.
});
try {
  const page = await browser.newPage({ viewport: { width: 960, height: 640 } });
  const logs = [];
  page.on("console", (m) => logs.push(m.text()));
  page.on("pageerror", (e) => logs.push(String(e)));
  const q = new URLSearchParams({ file: "/model.glb", node, eye, target });
  await page.goto(`http://127.0.0.1:${port}/page.html?${q}`);
  const info = await page.evaluate(() => window.ready);
  const shots = [];
  for (const t of times) {
    const s = await page.evaluate((t) => window.show(t), Number(t));
    const png = `${out}_t${t}.png`;
    await page.locator("canvas").screenshot({ path: png });
    // Share of pixels that differ from the white background.
    const filled = await page.evaluate(() => {
      const c = document.querySelector("canvas");
      const g = document.createElement("canvas");
      g.width = c.width; g.height = c.height;
      const x = g.getContext("2d");
      x.drawImage(c, 0, 0);
      const d = x.getImageData(0, 0, c.width, c.height).data;
      let n = 0;
      for (let i = 0; i < d.length; i += 4) if (d[i] < 245 || d[i + 1] < 245 || d[i + 2] < 245) n++;
      return n / (d.length / 4);
    });
    shots.push({ t: Number(t), png, filled, ...s });
  }
  console.log(JSON.stringify({ ...info, shots, logs: logs.slice(0, 20) }));
} finally {
  await browser.close();
  server.close();
}
