// Headless Chromium driven over the DevTools protocol (a pipe, no port, no network), for the
// viewer page's tests and for the pictures in docs/images. Node 18+, no packages.
//
// Chromium runs as Debian ships it: headless, software GL (SwiftShader through ANGLE), no
// sandbox (tests run as root), no background networking, a fresh profile per launch.
import { spawn } from 'node:child_process';
import { existsSync, mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, delimiter } from 'node:path';
import { inflateSync } from 'node:zlib';

// The browser: $CHROMIUM, else chromium on the PATH. null when there is none.
export function findChromium() {
  if (process.env.CHROMIUM) return existsSync(process.env.CHROMIUM) ? process.env.CHROMIUM : null;
  for (const dir of (process.env.PATH || '').split(delimiter)) {
    for (const name of ['chromium', 'chromium-browser']) {
      const path = join(dir, name);
      if (dir && existsSync(path)) return path;
    }
  }
  return null;
}

export class Browser {
  static async launch(executable, { width = 1280, height = 800 } = {}) {
    const profile = mkdtempSync(join(tmpdir(), 'skinspheres-chromium-'));
    const args = [
      '--headless', '--no-sandbox', '--disable-gpu', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
      '--disable-background-networking', '--disable-component-update', '--disable-sync', '--disable-quic',
      '--disable-default-apps', '--disable-extensions', '--no-first-run', '--no-default-browser-check',
      '--mute-audio', '--hide-scrollbars', `--window-size=${width},${height}`, `--user-data-dir=${profile}`,
      '--remote-debugging-pipe', 'about:blank'];
    const child = spawn(executable, args, { stdio: ['ignore', 'ignore', 'pipe', 'pipe', 'pipe'] });
    const browser = new Browser(child, profile, width, height);
    try {
      await Promise.race([browser._attach(), new Promise((_, reject) => setTimeout(() => reject(new Error(
        `chromium did not answer within 60 s\n${browser.stderr.slice(-2000)}`)), 60000).unref())]);
    } catch (e) {
      child.kill('SIGKILL');
      rmSync(profile, { recursive: true, force: true });
      throw e;
    }
    return browser;
  }

  constructor(child, profile, width, height) {
    this.child = child;
    this.profile = profile;
    this.width = width;
    this.height = height;
    this.nextId = 1;
    this.pending = new Map();
    this.listeners = [];
    this.stderr = '';
    let buffer = Buffer.alloc(0);
    child.stderr.on('data', (d) => { this.stderr += d.toString(); });
    child.stdio[4].on('data', (d) => {
      buffer = Buffer.concat([buffer, d]);
      for (let end = buffer.indexOf(0); end >= 0; end = buffer.indexOf(0)) {
        const message = JSON.parse(buffer.subarray(0, end).toString());
        buffer = buffer.subarray(end + 1);
        if (message.id !== undefined && this.pending.has(message.id)) {
          const { resolve, reject, method } = this.pending.get(message.id);
          this.pending.delete(message.id);
          if (message.error) reject(new Error(`${method}: ${message.error.message}`));
          else resolve(message.result);
        } else {
          for (const listener of this.listeners) listener(message);
        }
      }
    });
    this.exited = new Promise((resolve) => child.on('exit', resolve));
    this.exited.then(() => {
      for (const { reject, method } of this.pending.values()) reject(new Error(`${method}: chromium exited\n${this.stderr.slice(-2000)}`));
      this.pending.clear();
    });
  }

  send(method, params = {}, sessionId = this.sessionId) {
    const id = this.nextId++;
    const message = { id, method, params };
    if (sessionId) message.sessionId = sessionId;
    return new Promise((resolve, reject) => {
      this.pending.set(id, { resolve, reject, method });
      this.child.stdio[3].write(JSON.stringify(message) + '\0');
    });
  }

  async _attach() {
    const { targetId } = await this.send('Target.createTarget', { url: 'about:blank' }, null);
    const { sessionId } = await this.send('Target.attachToTarget', { targetId, flatten: true }, null);
    this.sessionId = sessionId;
    await this.send('Runtime.enable');
    await this.send('Log.enable');
    await this.send('Page.enable');
    await this.send('Emulation.setDeviceMetricsOverride', { width: this.width, height: this.height, deviceScaleFactor: 1, mobile: false });
  }

  // Console messages and exceptions of the page, as { level, text } (level: error, warning, info).
  collectConsole() {
    const messages = [];
    this.listeners.push((m) => {
      if (m.method === 'Runtime.consoleAPICalled') {
        const text = m.params.args.map((a) => (a.value !== undefined ? String(a.value) : a.description || a.type)).join(' ');
        const level = m.params.type === 'error' || m.params.type === 'assert' ? 'error' : m.params.type === 'warning' ? 'warning' : 'info';
        messages.push({ level, source: 'console', text });
      } else if (m.method === 'Runtime.exceptionThrown') {
        const d = m.params.exceptionDetails;
        messages.push({ level: 'error', source: 'exception', text: (d.exception && d.exception.description) || d.text });
      } else if (m.method === 'Log.entryAdded') {
        const e = m.params.entry;
        messages.push({ level: e.level === 'error' ? 'error' : e.level === 'warning' ? 'warning' : 'info', source: e.source, text: e.text });
      }
    });
    return messages;
  }

  async navigate(url) {
    const loaded = new Promise((resolve) => {
      const listener = (m) => {
        if (m.method === 'Page.loadEventFired') {
          this.listeners.splice(this.listeners.indexOf(listener), 1);
          resolve();
        }
      };
      this.listeners.push(listener);
    });
    const result = await this.send('Page.navigate', { url });
    if (result.errorText) throw new Error(`navigate ${url}: ${result.errorText}`);
    await loaded;
  }

  async evaluate(expression) {
    const r = await this.send('Runtime.evaluate', { expression, returnByValue: true, awaitPromise: true });
    if (r.exceptionDetails) throw new Error(`evaluate ${expression}: ${r.exceptionDetails.exception?.description || r.exceptionDetails.text}`);
    return r.result.value;
  }

  // Waits until `expression` is truthy (polling), or throws after timeoutMs.
  async waitFor(expression, timeoutMs = 20000) {
    const start = Date.now();
    for (;;) {
      const value = await this.evaluate(expression);
      if (value) return value;
      if (Date.now() - start > timeoutMs) throw new Error(`timed out waiting for ${expression}`);
      await new Promise((r) => setTimeout(r, 50));
    }
  }

  // Lets the page render: two animation frames.
  async settle() {
    await this.evaluate('new Promise(r => requestAnimationFrame(() => requestAnimationFrame(() => r(true))))');
  }

  async click(x, y) {
    for (const type of ['mouseMoved', 'mousePressed', 'mouseReleased']) {
      await this.send('Input.dispatchMouseEvent', { type, x, y, button: 'left', buttons: type === 'mousePressed' ? 1 : 0, clickCount: 1 });
    }
  }

  // The viewport as a PNG (bytes) and decoded ({ width, height, rgba }).
  async screenshot() {
    const { data } = await this.send('Page.captureScreenshot', { format: 'png' });
    const png = Buffer.from(data, 'base64');
    return { png, image: decodePng(png) };
  }

  async close() {
    try {
      await Promise.race([this.send('Browser.close', {}, null), new Promise((r) => setTimeout(r, 3000))]);
    } catch (e) {
      // already gone
    }
    const timer = setTimeout(() => this.child.kill('SIGKILL'), 3000);
    await this.exited;
    clearTimeout(timer);
    rmSync(this.profile, { recursive: true, force: true });
  }
}

// PNG (8-bit greyscale/RGB/RGBA, non-interlaced, as Chromium writes) -> { width, height, rgba }.
export function decodePng(png) {
  if (png.readUInt32BE(0) !== 0x89504e47) throw new Error('not a PNG');
  let offset = 8, width = 0, height = 0, colorType = 0, bitDepth = 0, interlace = 0;
  const idat = [];
  while (offset < png.length) {
    const length = png.readUInt32BE(offset);
    const type = png.toString('latin1', offset + 4, offset + 8);
    const body = png.subarray(offset + 8, offset + 8 + length);
    if (type === 'IHDR') {
      width = body.readUInt32BE(0);
      height = body.readUInt32BE(4);
      bitDepth = body[8];
      colorType = body[9];
      interlace = body[12];
    } else if (type === 'IDAT') {
      idat.push(body);
    } else if (type === 'IEND') {
      break;
    }
    offset += 12 + length;
  }
  const channels = { 0: 1, 2: 3, 4: 2, 6: 4 }[colorType];
  if (bitDepth !== 8 || !channels || interlace) throw new Error(`unsupported PNG (depth ${bitDepth}, colour ${colorType}, interlace ${interlace})`);
  const raw = inflateSync(Buffer.concat(idat));
  const stride = width * channels;
  const pixels = Buffer.alloc(stride * height);
  for (let y = 0; y < height; ++y) {
    const filter = raw[y * (stride + 1)];
    const line = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
    const out = pixels.subarray(y * stride, (y + 1) * stride);
    const prev = y > 0 ? pixels.subarray((y - 1) * stride, y * stride) : Buffer.alloc(stride);
    for (let x = 0; x < stride; ++x) {
      const a = x >= channels ? out[x - channels] : 0, b = prev[x], c = x >= channels ? prev[x - channels] : 0;
      let v = line[x];
      if (filter === 1) v += a;
      else if (filter === 2) v += b;
      else if (filter === 3) v += (a + b) >> 1;
      else if (filter === 4) {
        const p = a + b - c, pa = Math.abs(p - a), pb = Math.abs(p - b), pc = Math.abs(p - c);
        v += pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
      }
      out[x] = v & 255;
    }
  }
  const rgba = Buffer.alloc(width * height * 4);
  for (let i = 0; i < width * height; ++i) {
    const p = pixels.subarray(i * channels, (i + 1) * channels);
    if (channels >= 3) { rgba[4 * i] = p[0]; rgba[4 * i + 1] = p[1]; rgba[4 * i + 2] = p[2]; }
    else { rgba[4 * i] = rgba[4 * i + 1] = rgba[4 * i + 2] = p[0]; }
    rgba[4 * i + 3] = channels === 4 ? p[3] : channels === 2 ? p[1] : 255;
  }
  return { width, height, rgba };
}

// Pixels of `image` inside box (CSS px = image px at scale 1) whose colour is within `tolerance`
// of [r, g, b] on every channel.
export function countColor(image, [r, g, b], box = null, tolerance = 24) {
  const x0 = Math.max(0, Math.floor(box ? box.left : 0)), x1 = Math.min(image.width, Math.ceil(box ? box.right : image.width));
  const y0 = Math.max(0, Math.floor(box ? box.top : 0)), y1 = Math.min(image.height, Math.ceil(box ? box.bottom : image.height));
  let n = 0;
  for (let y = y0; y < y1; ++y) {
    for (let x = x0; x < x1; ++x) {
      const i = 4 * (y * image.width + x);
      if (Math.abs(image.rgba[i] - r) <= tolerance && Math.abs(image.rgba[i + 1] - g) <= tolerance && Math.abs(image.rgba[i + 2] - b) <= tolerance) ++n;
    }
  }
  return n;
}
