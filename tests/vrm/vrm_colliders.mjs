// An independent check of `skinspheres colliders --format vrm1|vrm0`: the written GLB loaded by
// three.js's GLTFLoader with @pixiv/three-vrm-springbone's loader plugin (the reader VRM apps use,
// pinned in package-lock.json), nothing from skinspheres.
//
//   node tests/vrm/vrm_colliders.mjs OUT.glb REPORT.json [--fps F] [--min-covered S] [--max-standoff S]
//        [--tolerance S] [--agree S]
//
// 1. Every collider the report lists is attached to the node of its joint, in the loader's own
//    as the spring-bone plugin attaches them (VRM 1.0 or 0.x, as the file says).
// 2. The mesh is posed by three.js (AnimationMixer, SkinnedMesh.getVertexPosition) at the rest pose
//    and every frame of every clip at F fps, and each vertex is measured against the loaded colliders
//    by the plugin's own collision code (shape.calculateCollision with a zero radius: the signed
//    distance). Per pose: the share of vertices inside or within the tolerance (a share of the rest
//    height), and the standoff (mean depth under the colliders' surface, 0 outside).
// Prints the worst pose's coverage and the mean standoff; exits 1 when below --min-covered, above
// --max-standoff, or differing from the report's by more than --agree (absolute shares), 2 on bad
// input. Node has no image decoder: the file's textures are dropped before loading.
import { readFileSync } from 'node:fs';
import * as THREE from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
import { VRMSpringBoneCollider, VRMSpringBoneLoaderPlugin } from '@pixiv/three-vrm-springbone';

function fail(message) {
  console.error(`vrm_colliders: ${message}`);
  process.exit(2);
}

const args = process.argv.slice(2);
if (args.length < 2) fail('usage: vrm_colliders.mjs OUT.glb REPORT.json [--fps F] [--min-covered S] [--max-standoff S]');
const option = (name, fallback) => {
  const i = args.indexOf(name);
  return i >= 0 ? Number(args[i + 1]) : fallback;
};
const fps = option('--fps', 30);
const minCovered = option('--min-covered', NaN);
const maxStandoff = option('--max-standoff', NaN);
const agree = option('--agree', NaN);
const report = JSON.parse(readFileSync(args[1], 'utf8'));
const tolerance = option('--tolerance', report.tolerance_share);

// The GLB without textures (Node cannot decode images), as an ArrayBuffer.
function loadGlb(path) {
  const bytes = readFileSync(path);
  if (bytes.readUInt32LE(0) !== 0x46546c67) fail(`${path}: not a GLB file`);
  const jsonLength = bytes.readUInt32LE(12);
  const json = JSON.parse(bytes.subarray(20, 20 + jsonLength).toString('utf8'));
  delete json.images;
  delete json.textures;
  delete json.samplers;
  for (const m of json.materials ?? []) {
    const strip = (o) => {
      for (const k of Object.keys(o)) {
        if (k.endsWith('Texture')) delete o[k];
        else if (o[k] && typeof o[k] === 'object') strip(o[k]);
      }
    };
    strip(m);
  }
  let text = Buffer.from(JSON.stringify(json), 'utf8');
  const pad = (4 - (text.length % 4)) % 4;
  text = Buffer.concat([text, Buffer.alloc(pad, 0x20)]);
  const rest = bytes.subarray(20 + jsonLength);
  const header = Buffer.alloc(20);
  header.writeUInt32LE(0x46546c67, 0);
  header.writeUInt32LE(2, 4);
  header.writeUInt32LE(20 + text.length + rest.length, 8);
  header.writeUInt32LE(text.length, 12);
  header.writeUInt32LE(0x4e4f534a, 16);
  const out = Buffer.concat([header, text, rest]);
  return out.buffer.slice(out.byteOffset, out.byteOffset + out.byteLength);
}

const loader = new GLTFLoader();
loader.register((parser) => new VRMSpringBoneLoaderPlugin(parser));
const gltf = await new Promise((resolve, reject) => loader.parse(loadGlb(args[0]), '', resolve, reject)).catch((e) =>
  fail(`${args[0]}: three.js could not load it: ${e.message ?? e}`),
);
if (!gltf.userData.vrmSpringBoneManager) {
  fail(`${args[0]}: the spring-bone plugin found no VRMC_springBone or VRM 0.x secondaryAnimation`);
}
// The colliders the plugin attached to nodes (springs may reference them or not: all are checked).
const colliders = [];
gltf.scene.traverse((o) => {
  if (o instanceof VRMSpringBoneCollider) colliders.push(o);
});

// 1. Attached where the report says: each collider's parent object is a glTF node (the loader's
// associations give its index) whose name in the file is the report's joint.
const nodeNames = gltf.parser.json.nodes.map((n, i) => n.name ?? `node_${i}`);
const expected = report.colliders.map((c) => c.joint).sort();
const attached = colliders
  .map((c) => {
    const index = gltf.parser.associations.get(c.parent)?.nodes;
    return index === undefined ? '(not a node)' : nodeNames[index];
  })
  .sort();
if (JSON.stringify(attached) !== JSON.stringify(expected)) {
  console.log(`FAIL: colliders attached to ${attached.join(', ')}; the report says ${expected.join(', ')}`);
  process.exit(1);
}

// 2. Coverage over the poses.
const scene = gltf.scene;
const meshes = [];
scene.traverse((o) => {
  if (o.isMesh) meshes.push(o);
});
const mixer = new THREE.AnimationMixer(scene);
const v = new THREE.Vector3();
const target = new THREE.Vector3();

function pose() {
  scene.updateMatrixWorld(true);
  for (const c of colliders) c.updateWorldMatrix(true, false);
  const out = [];
  for (const m of meshes) {
    const n = m.geometry.attributes.position.count;
    for (let i = 0; i < n; ++i) {
      m.getVertexPosition(i, v);
      out.push(v.clone().applyMatrix4(m.matrixWorld));
    }
  }
  return out;
}

const rest = pose();
let lo = Infinity;
let hi = -Infinity;
for (const p of rest) (lo = Math.min(lo, p.y)), (hi = Math.max(hi, p.y));
const height = hi - lo;

function measure(points) {
  let covered = 0;
  let depth = 0;
  for (const p of points) {
    let d = Infinity;
    for (const c of colliders) d = Math.min(d, c.shape.calculateCollision(c.colliderMatrix, p, 0, target));
    if (d <= tolerance * height) ++covered;
    depth += Math.max(0, -d);
  }
  return { covered: covered / points.length, standoff: depth / points.length / height };
}

const results = [measure(rest)];
for (const clip of gltf.animations) {
  mixer.stopAllAction();
  const action = mixer.clipAction(clip);
  action.play();
  const frames = Math.floor(clip.duration * fps + 1e-3) + 1;
  for (let f = 0; f < frames; ++f) {
    action.time = Math.min(f / fps, clip.duration);
    mixer.update(0);
    results.push(measure(pose()));
  }
  action.stop();
}
const worst = Math.min(...results.map((r) => r.covered));
const standoff = results.reduce((s, r) => s + r.standoff, 0) / results.length;
console.log(
  `${colliders.length} colliders attached to their joints; ${results.length} poses: covered ` +
    `${(100 * worst).toFixed(2)}% (worst pose), standoff ${(100 * standoff).toFixed(2)}% of height (mean)`,
);
const ours = report.summary;
let ok = true;
if (worst < minCovered) (ok = false), console.log(`FAIL: worst pose covered below ${100 * minCovered}%`);
if (standoff > maxStandoff) (ok = false), console.log(`FAIL: standoff above ${100 * maxStandoff}%`);
if (Math.abs(worst - ours.min_covered) > agree || Math.abs(standoff - ours.mean_standoff_share) > agree) {
  ok = false;
  console.log(
    `FAIL: the report says ${(100 * ours.min_covered).toFixed(2)}% and ${(100 * ours.mean_standoff_share).toFixed(2)}%`,
  );
}
process.exit(ok ? 0 : 1);
