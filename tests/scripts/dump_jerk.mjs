// Jerk of two played clips, compared: node tests/scripts/dump_jerk.mjs SOURCE.jsonl FIXED.jsonl FPS
//   [--max-ratio R]
//
// Each dump is `skinspheres play ... --dump`: per frame the world positions of the skin joints
// ("joints"). For every joint whose position differs between the two dumps on some frame (by more
// than 1e-6 of the rest height), the third difference of its position times FPS^3, per frame; the
// RMS over those joints and frames for each dump, and their ratio. Nothing from skinspheres but the
// dumps. Exits 1 when the ratio is over --max-ratio, 2 on bad input.
import { readFileSync } from 'node:fs';

function fail(message) {
  console.error(`dump_jerk: ${message}`);
  process.exit(2);
}
const [sourcePath, fixedPath, fpsText, ...rest] = process.argv.slice(2);
if (!sourcePath || !fixedPath || !(Number(fpsText) > 0)) fail('usage: SOURCE.jsonl FIXED.jsonl FPS [--max-ratio R]');
const fps = Number(fpsText);
const maxRatio = rest[0] === '--max-ratio' ? Number(rest[1]) : Infinity;

function frames(path) {
  const lines = readFileSync(path, 'utf8').split('\n').filter((l) => l.trim().length > 0);
  return lines.map((l) => JSON.parse(l).joints);
}
const a = frames(sourcePath), b = frames(fixedPath);
if (a.length !== b.length || a.length === 0) fail(`the dumps hold ${a.length} and ${b.length} frames`);
const joints = a[0].length;
let top = -Infinity, bottom = Infinity;
for (const p of a[0]) top = Math.max(top, p[1]), bottom = Math.min(bottom, p[1]);
const height = Math.max(top - bottom, 1e-9);
const moved = [];
for (let j = 0; j < joints; ++j) {
  let far = 0;
  for (let f = 0; f < a.length; ++f) far = Math.max(far, Math.hypot(...[0, 1, 2].map((c) => a[f][j][c] - b[f][j][c])));
  if (far > 1e-6 * height) moved.push(j);
}
function rms(p) {
  let sum = 0, n = 0;
  for (const j of moved) {
    for (let f = 0; f + 3 < p.length; ++f) {
      const d = [0, 1, 2].map((c) => (p[f + 3][j][c] - 3 * p[f + 2][j][c] + 3 * p[f + 1][j][c] - p[f][j][c]) * fps ** 3);
      sum += d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
      ++n;
    }
  }
  return n ? Math.sqrt(sum / n) : 0;
}
const js = rms(a), jf = rms(b);
const ratio = js > 0 ? jf / js : jf > 0 ? Infinity : 1;
console.log(`jerk over ${moved.length} moved joints: source ${js.toPrecision(4)}, fixed ${jf.toPrecision(4)}, ratio ${ratio.toFixed(3)}`);
process.exit(ratio > maxRatio ? 1 : 0);
