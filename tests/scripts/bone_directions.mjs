// An independent check of retargeting: node tests/scripts/bone_directions.mjs SOURCE.glb
// TARGET.glb DUMP.jsonl CLIP [--max-median DEG] [--max-p95 DEG] [--map MAP.json] [--align bind|nodes]
//
// DUMP.jsonl is `skinspheres play TARGET --clips SOURCE --clip CLIP --dump DUMP.jsonl`: per frame
// the clip time sampled and the world positions of TARGET's skin joints ("joints", names in the
// first line's "joint_names"). This script reads SOURCE itself (its own GLB reader, sampler and
// forward kinematics, nothing from skinspheres), samples CLIP at each frame's clip time, and
// compares every bone's world direction (a skin joint and its nearest skin ancestor in TARGET,
// both matched by name to SOURCE's skin joints: the nodes that move its mesh; other nodes may
// carry keys no one sees) with the source's, after one rotation that aligns the two rest poses
// (least squares over the matched joints' bind positions, IBM⁻¹ of each file; with --align nodes,
// their node-tree rest positions, for files whose skins are bound in another space). --map: the
// --joint-map the dump was made with ({"source joint": "target joint"}), before names.
// Prints the median, 95th percentile and largest angle, and the bones with the largest median;
// exits 1 when a bound given is exceeded, 2 on bad input.
import { readFileSync } from 'node:fs';

function fail(message) {
  console.error(`bone_directions: ${message}`);
  process.exit(2);
}

// ----------------------------------------------------------------------------------------------
// GLB

function readGlb(path) {
  const bytes = readFileSync(path);
  if (bytes.readUInt32LE(0) !== 0x46546c67) fail(`${path}: not a GLB file`);
  const jsonLength = bytes.readUInt32LE(12);
  const json = JSON.parse(bytes.subarray(20, 20 + jsonLength).toString('utf8'));
  const binOffset = 20 + jsonLength;
  const bin = binOffset + 8 <= bytes.length ? bytes.subarray(binOffset + 8, binOffset + 8 + bytes.readUInt32LE(binOffset)) : null;
  return { json, bin, path };
}

const COMPONENTS = { SCALAR: 1, VEC2: 2, VEC3: 3, VEC4: 4, MAT4: 16 };

function accessor(glb, index) {
  const a = glb.json.accessors[index];
  const view = glb.json.bufferViews[a.bufferView];
  const n = COMPONENTS[a.type];
  const size = { 5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4 }[a.componentType];
  const stride = view.byteStride || n * size;
  const base = (view.byteOffset || 0) + (a.byteOffset || 0);
  const out = [];
  for (let i = 0; i < a.count; ++i) {
    const e = [];
    for (let c = 0; c < n; ++c) {
      const at = base + i * stride + c * size;
      let v;
      switch (a.componentType) {
        case 5126: v = glb.bin.readFloatLE(at); break;
        case 5120: v = a.normalized ? Math.max(glb.bin.readInt8(at) / 127, -1) : glb.bin.readInt8(at); break;
        case 5121: v = a.normalized ? glb.bin.readUInt8(at) / 255 : glb.bin.readUInt8(at); break;
        case 5122: v = a.normalized ? Math.max(glb.bin.readInt16LE(at) / 32767, -1) : glb.bin.readInt16LE(at); break;
        case 5123: v = a.normalized ? glb.bin.readUInt16LE(at) / 65535 : glb.bin.readUInt16LE(at); break;
        default: v = glb.bin.readUInt32LE(at);
      }
      e.push(v);
    }
    out.push(e);
  }
  return out;
}

// ----------------------------------------------------------------------------------------------
// Math: 4x4 column-major arrays, quaternions [x, y, z, w]

function mul(a, b) {
  const r = new Array(16).fill(0);
  for (let c = 0; c < 4; ++c) for (let row = 0; row < 4; ++row) for (let k = 0; k < 4; ++k) r[c * 4 + row] += a[k * 4 + row] * b[c * 4 + k];
  return r;
}
function trs(t, q, s) {
  const [x, y, z, w] = q;
  const r = [1 - 2 * (y * y + z * z), 2 * (x * y + z * w), 2 * (x * z - y * w),
             2 * (x * y - z * w), 1 - 2 * (x * x + z * z), 2 * (y * z + x * w),
             2 * (x * z + y * w), 2 * (y * z - x * w), 1 - 2 * (x * x + y * y)];
  return [r[0] * s[0], r[1] * s[0], r[2] * s[0], 0, r[3] * s[1], r[4] * s[1], r[5] * s[1], 0,
          r[6] * s[2], r[7] * s[2], r[8] * s[2], 0, t[0], t[1], t[2], 1];
}
function invertAffine(m) {  // general 3x3 inverse plus translation
  const a = [m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]];  // columns
  const det = a[0] * (a[4] * a[8] - a[7] * a[5]) - a[3] * (a[1] * a[8] - a[7] * a[2]) + a[6] * (a[1] * a[5] - a[4] * a[2]);
  const i = [(a[4] * a[8] - a[7] * a[5]) / det, -(a[1] * a[8] - a[7] * a[2]) / det, (a[1] * a[5] - a[4] * a[2]) / det,
             -(a[3] * a[8] - a[6] * a[5]) / det, (a[0] * a[8] - a[6] * a[2]) / det, -(a[0] * a[5] - a[3] * a[2]) / det,
             (a[3] * a[7] - a[6] * a[4]) / det, -(a[0] * a[7] - a[6] * a[1]) / det, (a[0] * a[4] - a[3] * a[1]) / det];
  const t = [m[12], m[13], m[14]];
  const it = [0, 1, 2].map((r) => -(i[r] * t[0] + i[3 + r] * t[1] + i[6 + r] * t[2]));
  return [i[0], i[1], i[2], 0, i[3], i[4], i[5], 0, i[6], i[7], i[8], 0, it[0], it[1], it[2], 1];
}
function slerp(a, b, u) {
  let d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
  const bb = d < 0 ? b.map((v) => -v) : b;
  d = Math.abs(d);
  if (d > 0.9995) return normalize(a.map((v, k) => v + (bb[k] - v) * u));
  const th = Math.acos(d), s = Math.sin(th);
  return a.map((v, k) => (Math.sin((1 - u) * th) * v + Math.sin(u * th) * bb[k]) / s);
}
function normalize(v) {
  const n = Math.hypot(...v);
  return n > 0 ? v.map((x) => x / n) : v;
}
const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];

// The rotation R (row-major 3x3) minimising Σ |R s_i - t_i|² over centred points (Horn's
// quaternion method: the eigenvector of the largest eigenvalue of a symmetric 4x4, by power
// iteration on the shifted matrix).
function alignRotation(s, t) {
  const cs = [0, 0, 0], ct = [0, 0, 0];
  s.forEach((p) => { for (let k = 0; k < 3; ++k) cs[k] += p[k] / s.length; });
  t.forEach((p) => { for (let k = 0; k < 3; ++k) ct[k] += p[k] / t.length; });
  const S = [[0, 0, 0], [0, 0, 0], [0, 0, 0]];
  for (let i = 0; i < s.length; ++i) {
    const a = sub(s[i], cs), b = sub(t[i], ct);
    for (let r = 0; r < 3; ++r) for (let c = 0; c < 3; ++c) S[r][c] += a[r] * b[c];
  }
  const [[xx, xy, xz], [yx, yy, yz], [zx, zy, zz]] = S;
  const N = [[xx + yy + zz, yz - zy, zx - xz, xy - yx],
             [yz - zy, xx - yy - zz, xy + yx, zx + xz],
             [zx - xz, xy + yx, -xx + yy - zz, yz + zy],
             [xy - yx, zx + xz, yz + zy, -xx - yy + zz]];
  const shift = N.reduce((m, row) => m + row.reduce((a, v) => a + Math.abs(v), 0), 0);
  let q = [1, 0.1, 0.1, 0.1];
  for (let it = 0; it < 2000; ++it) {
    const next = N.map((row, r) => row.reduce((a, v, c) => a + v * q[c], 0) + shift * q[r]);
    q = normalize(next);
  }
  const [w, x, y, z] = q;
  return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
          [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
          [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]];
}
const apply = (R, v) => R.map((row) => dot(row, v));

// ----------------------------------------------------------------------------------------------
// Scene: nodes, worlds, animation sampling

function scene(glb) {
  const nodes = glb.json.nodes;
  const parent = new Array(nodes.length).fill(-1);
  nodes.forEach((n, i) => (n.children || []).forEach((c) => { parent[c] = i; }));
  const local = nodes.map((n) => ({
    matrix: n.matrix || null,
    t: n.translation || [0, 0, 0], r: n.rotation || [0, 0, 0, 1], s: n.scale || [1, 1, 1],
  }));
  return { nodes, parent, local };
}

function worlds(sc, locals) {
  const out = new Array(sc.nodes.length);
  const visit = (i) => {
    if (out[i]) return out[i];
    const l = locals[i];
    const m = l.matrix || trs(l.t, l.r, l.s);
    out[i] = sc.parent[i] < 0 ? m : mul(visit(sc.parent[i]), m);
    return out[i];
  };
  for (let i = 0; i < sc.nodes.length; ++i) visit(i);
  return out;
}

function sampleAnimation(glb, sc, name, time) {
  const anim = (glb.json.animations || []).find((a) => a.name === name);
  if (!anim) fail(`${glb.path}: no animation "${name}"`);
  const locals = sc.local.map((l) => ({ ...l }));
  for (const ch of anim.channels) {
    const smp = anim.samplers[ch.sampler];
    const times = accessor(glb, smp.input).map((v) => v[0]);
    const values = accessor(glb, smp.output);
    const cubic = smp.interpolation === 'CUBICSPLINE';
    const value = (k) => (cubic ? values[3 * k + 1] : values[k]);
    let k = 0;
    while (k + 1 < times.length && times[k + 1] <= time) ++k;
    let v;
    if (time <= times[0] || k + 1 >= times.length || smp.interpolation === 'STEP') {
      v = value(time <= times[0] ? 0 : k);
    } else {
      const dt = times[k + 1] - times[k], u = (time - times[k]) / dt;
      if (cubic) {
        const u2 = u * u, u3 = u2 * u;
        const p0 = values[3 * k + 1], m0 = values[3 * k + 2], p1 = values[3 * (k + 1) + 1], m1 = values[3 * (k + 1)];
        v = p0.map((_, c) => (2 * u3 - 3 * u2 + 1) * p0[c] + (u3 - 2 * u2 + u) * dt * m0[c] + (-2 * u3 + 3 * u2) * p1[c] + (u3 - u2) * dt * m1[c]);
      } else if (ch.target.path === 'rotation') {
        v = slerp(value(k), value(k + 1), u);
      } else {
        v = value(k).map((a, c) => a + (value(k + 1)[c] - a) * u);
      }
    }
    const l = locals[ch.target.node];
    l.matrix = null;
    if (ch.target.path === 'translation') l.t = v;
    else if (ch.target.path === 'rotation') l.r = normalize(v);
    else if (ch.target.path === 'scale') l.s = v;
  }
  return worlds(sc, locals);
}

// Bind-pose world positions of a file's skin joints (IBM⁻¹), by node.
function bindPositions(glb) {
  const out = new Map();
  for (const skin of glb.json.skins || []) {
    const ibm = accessor(glb, skin.inverseBindMatrices);
    skin.joints.forEach((node, k) => {
      if (!out.has(node)) out.set(node, invertAffine(ibm[k]).slice(12, 15));
    });
  }
  return out;
}

function key(name) {
  let k = String(name);
  const cut = Math.max(k.lastIndexOf(':'), k.lastIndexOf('|'));
  if (cut >= 0) k = k.slice(cut + 1);
  k = k.toLowerCase();
  const m = /^mixamorig\d*_?(.+)$/.exec(k);
  return m ? m[1] : k;
}

// ----------------------------------------------------------------------------------------------

const args = process.argv.slice(2);
if (args.length < 4) fail('usage: bone_directions.mjs SOURCE.glb TARGET.glb DUMP.jsonl CLIP [--max-median DEG] [--max-p95 DEG]');
const [sourcePath, targetPath, dumpPath, clip] = args;
const bound = (flag) => { const i = args.indexOf(flag); return i >= 0 ? Number(args[i + 1]) : Infinity; };
const option = (flag) => { const i = args.indexOf(flag); return i >= 0 ? args[i + 1] : null; };
const source = readGlb(sourcePath), target = readGlb(targetPath);
const ss = scene(source), ts = scene(target);
const lines = readFileSync(dumpPath, 'utf8').split('\n').filter((l) => l.trim());
const frames = lines.map((l) => JSON.parse(l));
const jointNames = frames[0].joint_names;
if (!jointNames) fail(`${dumpPath}: the first line has no "joint_names"`);

// Target skin joints (dump order) -> target nodes, and each one's nearest skin ancestor.
const targetNode = jointNames.map((n) => ts.nodes.findIndex((node) => node.name === n));
if (targetNode.some((n) => n < 0)) fail(`${dumpPath}: a joint name is not a node of ${targetPath}`);
const dumpIndexOfNode = new Map(targetNode.map((n, i) => [n, i]));
const sourceNodeOfKey = new Map();
ss.nodes.forEach((n, i) => { if (!sourceNodeOfKey.has(key(n.name))) sourceNodeOfKey.set(key(n.name), i); });
if (option('--map')) {  // mapped target names take their source node, before any name match
  const map = JSON.parse(readFileSync(option('--map'), 'utf8'));
  for (const [from, to] of Object.entries(map)) {
    const node = ss.nodes.findIndex((n) => n.name === from);
    if (to !== null && node >= 0) sourceNodeOfKey.set(key(to), node);
  }
}
const restPositions = (glb, sc) => {
  if (option('--align') !== 'nodes') return bindPositions(glb);
  const w = worlds(sc, sc.local), out = bindPositions(glb);
  for (const node of out.keys()) out.set(node, w[node].slice(12, 15));
  return out;
};
const sourceBind = restPositions(source, ss), targetBind = restPositions(target, ts);
const bones = [];
targetNode.forEach((node, i) => {
  let a = ts.parent[node];
  while (a >= 0 && !dumpIndexOfNode.has(a)) a = ts.parent[a];
  if (a < 0) return;
  const from = sourceNodeOfKey.get(key(ts.nodes[a].name)), to = sourceNodeOfKey.get(key(ts.nodes[node].name));
  if (from === undefined || to === undefined || !sourceBind.has(from) || !sourceBind.has(to)) return;
  bones.push({ name: jointNames[dumpIndexOfNode.get(a)], a: dumpIndexOfNode.get(a), b: i, from, to, errors: [] });
});

// One rotation aligning the rest poses: the bind positions of the matched joints.
const ps = [], pt = [];
targetNode.forEach((node) => {
  const s = sourceNodeOfKey.get(key(ts.nodes[node].name));
  if (s !== undefined && sourceBind.has(s) && targetBind.has(node)) {
    ps.push(sourceBind.get(s));
    pt.push(targetBind.get(node));
  }
});
if (ps.length < 3) fail('fewer than 3 matched joints with bind poses');
const R = alignRotation(ps, pt);

const all = [];
for (const fr of frames) {
  const w = sampleAnimation(source, ss, clip, fr.clip_time);
  for (const bone of bones) {
    const dt = sub(fr.joints[bone.b], fr.joints[bone.a]);
    const ds = apply(R, sub(w[bone.to].slice(12, 15), w[bone.from].slice(12, 15)));
    const nt = Math.hypot(...dt), ns = Math.hypot(...ds);
    if (!(nt > 1e-9) || !(ns > 1e-9)) continue;
    const deg = Math.acos(Math.max(-1, Math.min(1, dot(dt, ds) / (nt * ns)))) * 180 / Math.PI;
    bone.errors.push(deg);
    all.push(deg);
  }
}
if (!all.length) fail('no bone to compare');
const quantile = (v, q) => { const s = [...v].sort((x, y) => x - y); return s[Math.min(s.length - 1, Math.floor(q * (s.length - 1) + 0.5))]; };
const median = quantile(all, 0.5), p95 = quantile(all, 0.95), max = Math.max(...all);
const worst = bones.filter((b) => b.errors.length).map((b) => [b.name, quantile(b.errors, 0.5)]).sort((x, y) => y[1] - x[1]).slice(0, 5);
console.log(`bone directions, ${clip}: ${bones.length} bones x ${frames.length} frames: median ${median.toFixed(2)} deg, ` +
  `p95 ${p95.toFixed(2)} deg, max ${max.toFixed(2)} deg; largest medians: ` +
  worst.map(([n, d]) => `${n} ${d.toFixed(1)}`).join(', '));
if (median > bound('--max-median') || p95 > bound('--max-p95')) {
  console.error(`bone_directions: over the bounds (median <= ${bound('--max-median')}, p95 <= ${bound('--max-p95')})`);
  process.exit(1);
}
