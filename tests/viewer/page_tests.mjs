// The viewer page in headless Chromium: node page_tests.mjs <case> <dir>, on the pages that
// make_pages.cmake wrote into <dir>. Cases:
//   play   play.html (built-in, walk + touch): loads with no console error; at rest (touch frame
//          0) no pixel has the contact colour; at a frame where a hand is on the chest, the
//          contact colour covers pixels near the chest; the timeline jumps to a clicked mark;
//          clicking a sphere selects it; intersecting triangles (data generated here, injected
//          into a copy of the page) show in their colour where those triangles are, and only on
//          the frame that has them; the tool's own triangle pairs (the narrow phase): none at
//          rest, and at the hand-on-chest frame the triangle colour is on screen near the chest.
//   fit    fit.html (a character file with no clip, its bones in centimetres under a 0.01
//          armature): loads with no console error, the bind pose is drawn inside its spheres, the
//          loosest spheres are marked, the transport is disabled.
//   clips  clips.html (clips from an animation-only FBX, joints "mixamorig:<name>"): the same
//          contacts as the character's own clips, the contact and triangle colours on the chest.
//   pieces pieces.html (triangle pieces): a selected sphere's pieces drawn, inside the sphere.
// Pixel checks count exact colours: the contact markers and the intersecting triangles are unlit,
// opaque and drawn over everything, so their colour reaches the screen unchanged; the screen
// region comes from the page's own projection of the spheres (screenBox), checked at rest to
// hold none of that colour.
import { readFileSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { Browser, countColor, findChromium } from './browser.mjs';

const [caseName, dir] = process.argv.slice(2);
const RED = [255, 0, 0];
const MAGENTA = [255, 0, 255];
const ORANGE = [255, 159, 28];
const BACKGROUND = [42, 45, 51];

let failures = 0;
function check(ok, what) {
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`);
  if (!ok) ++failures;
}

// The page's data, read from the file the way the page reads it.
function pageData(file) {
  const html = readFileSync(file, 'utf8');
  const m = html.match(/<script id="ss-data" type="application\/json">([\s\S]*?)<\/script>/);
  return { html, data: JSON.parse(m[1]), span: [m.index, m.index + m[0].length] };
}

// Base64 of little-endian 32-bit values (the page data's arrays) as a typed array.
function typed(Type, b64) {
  const b = Buffer.from(b64, 'base64');
  return new Type(b.buffer.slice(b.byteOffset, b.byteOffset + b.length));
}

function spheresOf(data, predicate) {
  const out = [];
  for (let s = 0; s < data.spheres.count; ++s) if (predicate(s)) out.push(s);
  return out;
}
const partSpheres = (data, name) => spheresOf(data, (s) => data.spheres.parts[data.spheres.part[s]] === name);
function pad(box, px) { return { left: box.left - px, top: box.top - px, right: box.right + px, bottom: box.bottom + px }; }

// Pixels of `color` in `box` (default: the whole view), not counting the legend's swatches.
async function countOnView(browser, image, color, box = null) {
  const r = await browser.evaluate(`(() => {
    const c = document.getElementById('ss-canvas').getBoundingClientRect(), l = document.getElementById('ss-legend').getBoundingClientRect();
    return { canvas: { left: c.left, top: c.top, right: c.right, bottom: c.bottom }, legend: { left: l.left, top: l.top, right: l.right, bottom: l.bottom } };
  })()`);
  const clip = (a, b) => ({ left: Math.max(a.left, b.left), top: Math.max(a.top, b.top), right: Math.min(a.right, b.right), bottom: Math.min(a.bottom, b.bottom) });
  const region = box ? clip(box, r.canvas) : r.canvas;
  const legend = clip(region, r.legend);
  const inLegend = legend.right > legend.left && legend.bottom > legend.top ? countColor(image, color, legend, 10) : 0;
  return countColor(image, color, region, 10) - inLegend;
}

// Sets the hash (every display parameter spelled out) and waits for the page to draw it.
async function setHash(browser, hash) {
  const before = Number(await browser.evaluate('document.getElementById("ss-state").dataset.rendered || 0'));
  await browser.evaluate(`location.hash = ${JSON.stringify(hash)}`);
  await browser.waitFor(`Number(document.getElementById("ss-state").dataset.rendered) > ${before}`);
  await browser.settle();
}

// The character drawn by three.js (skinned on the GPU from the GLB) lies inside the spheres drawn
// from the runtime's per-frame data, pixel for pixel: every triangle is inside its sphere, so on
// screen every mesh pixel is covered by a sphere pixel. Catches a mesh posed, placed or scaled
// differently from the spheres. `where`: "clip=...&frame=..." or "" (bind pose).
// shapes 'colliders' (`colliders --html`): a mesh pixel counts as inside when a collider pixel lies
// within `slack` of the character's drawn height (the tolerance colliders are fitted to).
async function meshInsideSpheres(browser, where, shapes = 'spheres', allowed = 0.005, slack = 0) {
  const view = await browser.evaluate(`(() => {
    const c = document.getElementById('ss-canvas').getBoundingClientRect(), l = document.getElementById('ss-legend').getBoundingClientRect();
    return { c: [c.left, c.top, c.right, c.bottom], l: [l.left, l.top, l.right, l.bottom] };
  })()`);
  const off = (image, x, y) => {
    const i = 4 * (y * image.width + x);
    return Math.max(Math.abs(image.rgba[i] - BACKGROUND[0]), Math.abs(image.rgba[i + 1] - BACKGROUND[1]), Math.abs(image.rgba[i + 2] - BACKGROUND[2])) > 4;
  };
  const prefix = where ? `${where}&` : '';
  const show = shapes === 'colliders' ? 'spheres=0&colliders=1' : 'spheres=1&colliders=0';
  await setHash(browser, `#${prefix}mesh=off&${show}&contacts=0&loosest=0`);
  const spheres = (await browser.screenshot()).image;
  await setHash(browser, `#${prefix}mesh=solid&spheres=0&colliders=0&contacts=0&loosest=0`);
  const mesh = (await browser.screenshot()).image;
  const inView = (x, y) => x >= view.c[0] && x < view.c[2] && y >= view.c[1] && y < view.c[3] &&
    !(x >= view.l[0] && x < view.l[2] && y >= view.l[1] && y < view.l[3]);
  let top = Infinity, bottom = -Infinity;
  for (let y = Math.ceil(view.c[1]); y < Math.floor(view.c[3]); ++y) {
    for (let x = Math.ceil(view.c[0]); x < Math.floor(view.c[2]); ++x) {
      if (inView(x, y) && off(mesh, x, y)) (top = Math.min(top, y)), (bottom = Math.max(bottom, y));
    }
  }
  const reach = Math.ceil(slack * (bottom - top + 1));
  const covered = (x, y) => {
    for (let dy = -reach; dy <= reach; ++dy) {
      for (let dx = -reach; dx <= reach; ++dx) {
        if (dx * dx + dy * dy <= reach * reach && y + dy >= 0 && y + dy < spheres.height && x + dx >= 0 &&
            x + dx < spheres.width && off(spheres, x + dx, y + dy)) return true;
      }
    }
    return false;
  };
  let meshPixels = 0, outside = 0;
  for (let y = Math.ceil(view.c[1]); y < Math.floor(view.c[3]); ++y) {
    for (let x = Math.ceil(view.c[0]); x < Math.floor(view.c[2]); ++x) {
      if (!inView(x, y) || !off(mesh, x, y)) continue;
      ++meshPixels;
      if (!covered(x, y)) ++outside;
    }
  }
  check(meshPixels > 2000 && outside <= allowed * meshPixels,
    `${where || 'bind pose'}: the drawn mesh (${meshPixels} pixels) lies inside the drawn ${shapes} (${outside} pixels outside)`);
}

async function open(browser, file, hash) {
  await browser.navigate(`file://${file}${hash}`);
  await browser.waitFor('document.getElementById("ss-state").dataset.ready === "1"');
  await browser.settle();
}
async function goTo(browser, clip, frame) {
  await browser.evaluate(`location.hash = '#clip=${clip}&frame=${frame}'`);
  await browser.waitFor(`document.getElementById("ss-state").dataset.frame === "${frame}"`);
  await browser.settle();
}
const state = (browser) => browser.evaluate('Object.assign({}, document.getElementById("ss-state").dataset)');
const boxOf = (browser, ids, whole = false) => browser.evaluate(`skinspheresViewer.screenBox(${JSON.stringify(ids)}, ${whole})`);

// The touch clip's frame nearest the middle of the chest window (builtin_character.h:
// [0.8, 1.6] s) among the frames where a hand sphere touches a torso sphere.
function chestFrame(data, clip) {
  const sph = data.spheres;
  const hand = (s) => sph.joint_names[sph.joint[s]].includes('Hand');
  const torso = (s) => sph.parts[sph.part[s]] === 'torso';
  let best = -1;
  clip.pairs.forEach((p, f) => {
    for (let i = 0; i + 1 < p.length; i += 2) {
      if ((hand(p[i]) && torso(p[i + 1])) || (hand(p[i + 1]) && torso(p[i]))) {
        if (best < 0 || Math.abs(clip.time[f] - 1.2) < Math.abs(clip.time[best] - 1.2)) best = f;
      }
    }
  });
  return best;
}

// Loads, checks rest and chest frames; returns the data and the chest frame.
async function restAndChest(browser, file) {
  const { data } = pageData(file);
  const touch = data.clips.find((c) => c.name === 'touch' || c.name.endsWith('/touch'));
  check(!!touch, `${file}: has a touch clip`);
  await open(browser, file, `#clip=${encodeURIComponent(touch.name)}&frame=0`);
  let st = await state(browser);
  check(st.errors === '0' && !st.error, `page reports no error (errors=${st.errors}${st.error ? ', ' + st.error : ''})`);
  check(st.clip === touch.name && st.frame === '0', `hash picks clip ${touch.name} frame 0 (got ${st.clip} ${st.frame})`);
  check(st.pairs === '0', `touch frame 0 (T-pose) has no sphere pair (${st.pairs})`);
  let { image } = await browser.screenshot();
  const redAtRest = await countOnView(browser, image, RED);
  check(redAtRest === 0, `at rest no pixel has the contact colour (${redAtRest})`);

  const f = chestFrame(data, touch);
  check(f >= 0 && touch.time[f] >= 0.8 && touch.time[f] <= 1.6, `a hand touches the chest at frame ${f} (t=${touch.time[f]} s)`);
  await goTo(browser, encodeURIComponent(touch.name), f);
  st = await state(browser);
  ({ image } = await browser.screenshot());
  const chest = await boxOf(browser, partSpheres(data, 'torso'), true);
  const inChest = await countOnView(browser, image, RED, chest), all = await countOnView(browser, image, RED);
  check(Number(st.pairs) > 0, `frame ${f}: ${st.pairs} sphere pairs in contact`);
  check(inChest >= 150, `frame ${f}: ${inChest} contact-colour pixels near the chest (>= 150)`);
  check(inChest >= 0.8 * all, `frame ${f}: most contact-colour pixels are near the chest (${inChest} of ${all})`);
  await meshInsideSpheres(browser, `clip=${encodeURIComponent(touch.name)}&frame=${f}`);
  await triangleContacts(browser, data, touch);
  await setHash(browser, `#clip=${encodeURIComponent(touch.name)}&frame=${f}&mesh=solid&spheres=1&contacts=1&loosest=0`);
  return { data, touch, chestFrame: f };
}

// The narrow phase's intersecting triangles as the tool wrote them: none at rest (touch frame 0),
// and at the hand-on-chest frame (a hand triangle crossing a torso triangle, nearest the middle
// of the chest window) the triangle colour is on screen near the chest, and nowhere at rest.
async function triangleContacts(browser, data, touch) {
  const sph = data.spheres;
  const offsets = typed(Uint32Array, sph.owned_offsets), owned = typed(Uint32Array, sph.owned_triangles);
  const owner = new Map();
  for (let s = 0; s < sph.count; ++s) for (let k = offsets[s]; k < offsets[s + 1]; ++k) owner.set(owned[k], s);
  const hand = (t) => owner.has(t) && sph.joint_names[sph.joint[owner.get(t)]].includes('Hand');
  const torso = (t) => owner.has(t) && sph.parts[sph.part[owner.get(t)]] === 'torso';
  const tp = touch.triangle_pairs;
  check(Array.isArray(tp) && tp.length === touch.frames, `the page has the narrow phase's triangle pairs for every frame (${tp && tp.length})`);
  if (!Array.isArray(tp)) return;
  let f = -1;
  tp.forEach((p, frame) => {
    for (let i = 0; i + 1 < p.length; i += 2) {
      if ((hand(p[i]) && torso(p[i + 1])) || (hand(p[i + 1]) && torso(p[i]))) {
        if (f < 0 || Math.abs(touch.time[frame] - 1.2) < Math.abs(touch.time[f] - 1.2)) f = frame;
      }
    }
  });
  check(f >= 0 && touch.time[f] >= 0.8 && touch.time[f] <= 1.6,
    `a hand triangle crosses a chest triangle at frame ${f} (t=${touch.time[f]} s), ${f >= 0 ? tp[f].length / 2 : 0} triangle pairs`);
  check(tp[0].length === 0, `touch frame 0 (T-pose) has no intersecting triangles (${tp[0].length / 2})`);
  const name = encodeURIComponent(touch.name);
  await setHash(browser, `#clip=${name}&frame=0&mesh=solid&spheres=0&contacts=1&loosest=0`);
  let st = await state(browser);
  let { image } = await browser.screenshot();
  const atRest = await countOnView(browser, image, MAGENTA);
  check(st.trianglePairs === '0' && atRest === 0, `at rest no pixel has the triangle colour (${atRest})`);
  if (f < 0) return;
  await setHash(browser, `#clip=${name}&frame=${f}&mesh=solid&spheres=0&contacts=1&loosest=0`);
  st = await state(browser);
  ({ image } = await browser.screenshot());
  const chest = await boxOf(browser, partSpheres(data, 'torso'), true);
  const inChest = await countOnView(browser, image, MAGENTA, chest), all = await countOnView(browser, image, MAGENTA);
  check(st.trianglePairs === String(tp[f].length / 2), `frame ${f} shows ${st.trianglePairs} triangle pairs (${tp[f].length / 2} in the data)`);
  check(inChest >= 100, `frame ${f}: ${inChest} triangle-colour pixels near the chest (>= 100)`);
  check(inChest >= 0.9 * all, `frame ${f}: the triangle colour is near the chest only (${inChest} of ${all})`);
}

// The timeline shows triangle contacts, penetrating and touching in two colours (the kinds the
// data gives: deeper than the run's touch tolerance penetrates); sphere-only overlaps only when
// asked for: the walk, which touches nothing, has no row by default.
async function timelineKinds(browser, data) {
  for (const clip of data.clips) {
    let consistent = Array.isArray(clip.part_contacts) && clip.part_contacts.length === clip.frames;
    (clip.part_contacts || []).forEach((pc) => {
      for (let i = 0; i + 3 < pc.length; i += 4) consistent &&= pc[i + 2] === (pc[i + 3] > clip.touch_tolerance ? 1 : 0);
    });
    check(consistent, `${clip.name}: part_contacts for every frame, penetrating exactly when deeper than ${clip.touch_tolerance}`);
  }
  const walk = data.clips.find((c) => c.name === 'walk');
  await setHash(browser, '#clip=walk&frame=0&overlaps=0');
  let st = await state(browser);
  check(st.timelineRows === '0', `the walk touches nothing: no timeline row (${st.timelineRows})`);
  await setHash(browser, '#clip=walk&frame=1&overlaps=1');
  st = await state(browser);
  const overlapping = walk.pairs.some((p) => p.length > 0);
  check(!overlapping || Number(st.timelineRows) > 0, `sphere overlaps shown: the walk's rows appear (${st.timelineRows})`);
  await setHash(browser, '#clip=touch&frame=0&overlaps=0');
  const marks = await browser.evaluate(`(() => ({
    pen: document.querySelectorAll('#ss-timeline .row[data-parts="torso,arm_l"] .mark.pen').length,
    touch: document.querySelectorAll('#ss-timeline .mark.touch').length,
    sph: document.querySelectorAll('#ss-timeline .mark.sph').length,
    colours: [...new Set([...document.querySelectorAll('#ss-timeline .mark')].map((m) => getComputedStyle(m).backgroundColor))]
  }))()`);
  check(marks.pen > 0 && marks.touch > 0 && marks.sph === 0,
    `touch: penetrating marks on torso - arm_l (${marks.pen}), touching marks (${marks.touch}), no sphere-overlap mark (${marks.sph})`);
  check(marks.colours.length === 2, `two mark colours: ${marks.colours.join(', ')}`);
}

// Side-panel labels break between words only: no label takes more lines than it has words, even a
// clip name too long for its column (shown whole in its title, cut with an ellipsis).
async function labelsKeepWords(browser) {
  const broken = await browser.evaluate(`(() => {
    const name = document.querySelector('#ss-times td.name');
    if (name) name.textContent = 'Armature|mixamo.com|Layer0/RightHandThumb4_retargeted';
    const bad = [];
    document.querySelectorAll('#ss-side td:first-child').forEach((td) => {
      const text = td.textContent.trim();
      if (!text) return;
      const range = document.createRange();
      range.selectNodeContents(td);
      const lines = new Set([...range.getClientRects()].map((r) => Math.round(r.top))).size;
      if (lines > text.split(/\\s+/).length) bad.push(text);
    });
    return { bad, named: !!name };
  })()`);
  check(broken.named && broken.bad.length === 0, `side-panel labels break between words only (${broken.bad.join(' | ')})`);
}

async function casePlay(browser) {
  const file = join(dir, 'play.html');
  const { data, touch, chestFrame: f } = await restAndChest(browser, file);

  // Timeline: clicking a mark of the torso - arm_l row jumps to a frame of that mark.
  const mark = await browser.evaluate(`(() => {
    const m = document.querySelector('#ss-timeline .row[data-parts="torso,arm_l"] .mark');
    if (!m) return null;
    const r = m.getBoundingClientRect();
    return { x: r.left + r.width / 2, y: r.top + r.height / 2, first: +m.dataset.first, last: +m.dataset.last };
  })()`);
  check(!!mark, 'the timeline has a torso - arm_l row with a mark');
  if (mark) {
    await goTo(browser, 'touch', 0);
    await browser.click(mark.x, mark.y);
    await browser.settle();
    const st = await state(browser);
    check(+st.frame >= mark.first && +st.frame <= mark.last && +st.frame > 0,
      `clicking the mark [${mark.first}, ${mark.last}] jumps to frame ${st.frame}`);
  }

  await timelineKinds(browser, data);
  await labelsKeepWords(browser);

  // Picking: at rest, a click on the highest head sphere's centre selects a head sphere.
  await goTo(browser, 'touch', 0);
  const head = partSpheres(data, 'head');
  const rest = typed(Float32Array, data.spheres.rest_xyzr);
  const top = head.reduce((a, b) => (rest[4 * b + 1] > rest[4 * a + 1] ? b : a));
  const at = await boxOf(browser, [top]);
  await browser.click(at.left, at.top);
  await browser.settle();
  const st = await state(browser);
  const picked = Number(st.selected);
  check(picked >= 0 && data.spheres.parts[data.spheres.part[picked]] === 'head', `clicking sphere ${top} selects a head sphere (${picked})`);
  const panel = await browser.evaluate('document.getElementById("ss-pick-body").textContent');
  check(panel.includes('head') && panel.includes(String(data.spheres.triangles[picked])), 'the panel shows its part and triangle count');

  // Intersecting triangles (the narrow phase's output, generated here): at frame 0 of touch, the
  // triangles owned by the left arm's spheres, paired two by two; no pair on other frames.
  const { html, span } = pageData(file);
  const offsets = typed(Uint32Array, data.spheres.owned_offsets);
  const owned = typed(Uint32Array, data.spheres.owned_triangles);
  const arm = partSpheres(data, 'arm_l');
  const triangles = [];
  for (const s of arm) for (let k = offsets[s]; k < offsets[s + 1]; ++k) triangles.push(owned[k]);
  const pairs = [];
  for (let k = 0; k + 1 < triangles.length; k += 2) pairs.push(triangles[k], triangles[k + 1]);
  touch.triangle_pairs = touch.pairs.map((_, frame) => (frame === 0 ? pairs : []));
  const json = JSON.stringify(data).replace(/</g, '\\u003c');
  const injected = join(dir, 'play_triangles.html');
  writeFileSync(injected, html.slice(0, span[0]) + `<script id="ss-data" type="application/json">${json}</script>` + html.slice(span[1]));
  await open(browser, injected, '#clip=touch&frame=0&spheres=0');
  let s2 = await state(browser);
  check(s2.trianglePairs === String(pairs.length / 2), `frame 0 shows ${s2.trianglePairs} triangle pairs (${pairs.length / 2} given)`);
  let { image } = await browser.screenshot();
  const armBox = await boxOf(browser, arm, true);
  const inArm = await countOnView(browser, image, MAGENTA, armBox), all = await countOnView(browser, image, MAGENTA);
  check(inArm >= 300, `${inArm} triangle-colour pixels on the left arm (>= 300)`);
  check(inArm >= 0.95 * all, `the triangle colour is on the left arm only (${inArm} of ${all})`);
  const triMark = await browser.evaluate(`(() => {
    const m = document.querySelector('#ss-timeline .row[data-parts="arm_l,arm_l"] .mark.tri');
    return m ? [+m.dataset.first, +m.dataset.last] : null;
  })()`);
  check(triMark && triMark[0] === 0 && triMark[1] === 0, `the timeline marks them on the arm_l - arm_l row at frame 0 (${triMark})`);
  await goTo(browser, 'touch', 1);
  s2 = await state(browser);
  ({ image } = await browser.screenshot());
  const after = await countOnView(browser, image, MAGENTA);
  check(s2.trianglePairs === '0' && after === 0, `frame 1 (no triangle pairs): ${after} triangle-colour pixels`);
}

async function caseFit(browser) {
  const file = join(dir, 'fit.html');
  const { data } = pageData(file);
  check(data.clips.length === 0 && data.character.clips.length === 0, 'the fit page of a character without clips has no clip');
  await open(browser, file, '');
  const shown = await browser.evaluate('[document.getElementById("ss-file").textContent, document.title]');
  check(data.character.file.endsWith("cm rig <!-- <script><b>&'x'.glb") && shown[0] === data.character.file &&
    shown[1] === `skinspheres: ${data.character.file}`, `a file name with markup is shown as text: ${shown[0]}`);
  const st = await state(browser);
  check(st.errors === '0' && !st.error, `page reports no error (errors=${st.errors}${st.error ? ', ' + st.error : ''})`);
  check(st.clip === '' && st.pairs === '0', 'no clip, no contact');
  const disabled = await browser.evaluate('document.getElementById("ss-transport").classList.contains("disabled")');
  check(disabled, 'the transport is disabled');
  const label = await browser.evaluate('document.getElementById("ss-frame-label").textContent');
  check(/bind pose/.test(label), `the frame label says so: "${label}"`);
  const { image } = await browser.screenshot();
  const body = await boxOf(browser, spheresOf(data, () => true));
  const area = (body.right - body.left) * (body.bottom - body.top);
  const drawn = area - countColor(image, BACKGROUND, body, 3);
  check(drawn > 0.1 * area, `the character and spheres cover ${drawn} of ${Math.round(area)} pixels of their box`);
  const orange = countColor(image, ORANGE, pad(await boxOf(browser, data.metrics.loosest), 80), 40);
  check(data.metrics.loosest.length === 5 && orange >= 50, `${data.metrics.loosest.length} loosest spheres marked (${orange} marker pixels)`);
  const rows = await browser.evaluate('document.querySelectorAll("#ss-loose-body .link").length');
  check(rows === data.metrics.loosest.length, `the panel lists them (${rows})`);
  await meshInsideSpheres(browser, '');
}

async function caseClips(browser) {
  const file = join(dir, 'clips.html');
  const { data } = pageData(file);
  const names = data.clips.map((c) => c.name);
  check(names.includes('walk') && names.includes('touch'), `clips from the FBX: ${names.join(', ')}`);
  check(data.notes.some((n) => n.startsWith('clips from')), `the header says where they came from: ${data.notes[0]}`);
  const own = pageData(join(dir, 'play.html')).data.clips.find((c) => c.name === 'touch');
  const touch = data.clips.find((c) => c.name === 'touch');
  // The same poses as the character's own touch clip where it holds a pose (builtin_character.h:
  // chest [0.8, 1.6] s, head [2.4, 3.2] s). Between keys they differ: FBX curves are Euler angles,
  // which Assimp interpolates per axis, where the glTF clip slerps quaternions.
  const a = typed(Float32Array, own.spheres_xyzr);
  const b = typed(Float32Array, touch.spheres_xyzr);
  const S = data.spheres.count, height = data.metrics.body_height;
  let held = 0, worst = 0, samePairs = 0;
  touch.time.forEach((t, f) => {
    if (!((t >= 0.8 && t <= 1.6) || (t >= 2.4 && t <= 3.2))) return;
    ++held;
    for (let i = 4 * S * f; i < 4 * S * (f + 1); ++i) worst = Math.max(worst, Math.abs(a[i] - b[i]));
    if (JSON.stringify(touch.pairs[f]) === JSON.stringify(own.pairs[f])) ++samePairs;
  });
  check(held > 40 && worst <= 1e-3 * height, `held poses: spheres within ${(worst / height).toExponential(1)} of body height of the character's own clip (${held} frames)`);
  check(samePairs === held, `held poses: the same sphere pairs on ${samePairs} of ${held} frames`);
  await restAndChest(browser, file);
}

// The sphere owning the most pieces, selected at a frame of the touch clip: every one of its pieces
// is drawn (state "pieces"), in its colour on screen, and each drawn corner (skinned on the CPU from
// the GLB) lies inside that sphere as the runtime refitted it for the frame, to 0.5% of the height.
async function casePieces(browser) {
  const file = join(dir, 'pieces.html');
  const { data } = pageData(file);
  const offsets = typed(Uint32Array, data.spheres.piece_offsets);
  let best = -1;
  for (let s = 0; s < data.spheres.count; ++s) {
    if (best < 0 || offsets[s + 1] - offsets[s] > offsets[best + 1] - offsets[best]) best = s;
  }
  const count = offsets[best + 1] - offsets[best];
  check(count > 0, `sphere ${best} owns ${count} pieces`);
  const clip = data.clips.findIndex((c) => c.name === 'touch');
  const frame = 20;
  await open(browser, file, `#clip=${clip}&frame=${frame}&sphere=${best}&mesh=solid&spheres=0&contacts=0&loosest=0`);
  const st = await state(browser);
  check(st.errors === '0' && !st.error, `page reports no error (errors=${st.errors}${st.error ? ', ' + st.error : ''})`);
  check(st.pieces === String(count), `all ${count} pieces drawn (state pieces=${st.pieces})`);
  const { image } = await browser.screenshot();
  const green = await countOnView(browser, image, [0, 255, 128]);
  check(green > 20, `the pieces' colour is on screen (${green} pixels)`);
  const corners = await browser.evaluate('skinspheresViewer.pieceCorners()');
  const xyzr = typed(Float32Array, data.clips[clip].spheres_xyzr);
  const at = 4 * (data.spheres.count * frame + best);
  const height = data.metrics ? data.metrics.body_height : 1.8;
  let worst = -Infinity;
  for (let k = 0; k + 2 < corners.length; k += 3) {
    const d = Math.hypot(corners[k] - xyzr[at], corners[k + 1] - xyzr[at + 1], corners[k + 2] - xyzr[at + 2]) - xyzr[at + 3];
    worst = Math.max(worst, d);
  }
  check(corners.length === 9 * count && worst <= 0.005 * height,
    `the drawn corners (${corners.length / 3}) lie inside the sphere (farthest ${(worst / height).toExponential(1)} of the height beyond it)`);
}

const chromium = findChromium();
if (!chromium) {
  console.log('SKIPPED: chromium not found (scripts/deps installs Debian\'s chromium; or set CHROMIUM)');
  process.exit(0);
}
// `fix --html` at its default depth, the touch tolerance: one page holding the touch clip and
// "touch (fixed)"; the original penetrates (deeper than 2% of the height on some frame, the page's
// own part contacts), the fixed one is never deeper than the tolerance; the clip selector switches between them and the timeline follows (penetrating marks
// before, none after).
async function caseFix(browser) {
  const file = join(dir, 'fix', 'touch.html');
  const { data } = pageData(file);
  const names = data.clips.map((c) => c.name);
  check(names.length === 2 && names[0] === 'touch' && names[1] === 'touch (fixed)', `clips: ${names.join(', ')}`);
  const height = data.metrics.body_height;
  const deepest = (clip) => {
    let worst = 0;
    clip.part_contacts.forEach((pc) => {
      for (let i = 0; i + 3 < pc.length; i += 4) worst = Math.max(worst, pc[i + 3]);
    });
    return worst / height;
  };
  const [before, after] = data.clips.map(deepest);
  check(before > 0.02 && after * height <= data.clips[1].touch_tolerance, `deepest: ${(100 * before).toFixed(2)}% before, ${(100 * after).toFixed(2)}% after`);
  check(data.clips[0].frames === data.clips[1].frames, `as many frames (${data.clips[1].frames})`);
  await open(browser, file, '#clip=touch&frame=0');
  const pens = async () => browser.evaluate(`document.querySelectorAll('#ss-timeline .mark.pen').length`);
  const penBefore = await pens();
  await setHash(browser, `#clip=${encodeURIComponent('touch (fixed)')}&frame=0`);
  const penAfter = await pens();
  check(penBefore > 0 && penAfter === 0, `penetrating marks on the timeline: ${penBefore} before, ${penAfter} after`);
}

// `colliders --html`: the colliders drawn on the moving character. The page holds 32 shapes and, per
// clip, their placement at every frame; on screen the character (skinned by three.js from the GLB)
// lies inside the drawn colliders, or within 1% of its drawn height of them (the tolerance they
// are fitted to), on the walk's first frame and the touch clip's middle one; the toggle hides them.
async function caseColliders(browser) {
  const file = join(dir, 'colliders.html');
  const { data } = pageData(file);
  const col = data.colliders;
  check(col && col.shapes.length === 32, `32 colliders in the page (${col ? col.shapes.length : 0})`);
  check(col.rest.length === 6 * 32 && col.clips.length === data.clips.length, 'placements at rest and per clip');
  data.clips.forEach((c, k) => check(col.clips[k].length === c.frames, `${c.name}: a placement per frame`));
  const touch = data.clips.findIndex((c) => c.name === 'touch');
  const middle = Math.floor(data.clips[touch].frames / 2);
  await open(browser, file, '#mesh=xray');
  let st = await state(browser);
  check(st.errors === '0' && st.colliders === '32', `page reports no error and shows 32 colliders (${st.colliders})`);
  await meshInsideSpheres(browser, 'clip=walk&frame=0', 'colliders', 0.005, 0.01);
  await meshInsideSpheres(browser, `clip=touch&frame=${middle}`, 'colliders', 0.005, 0.01);
  await setHash(browser, `#clip=touch&frame=${middle}&colliders=0`);
  st = await state(browser);
  check(st.colliders === '0', `the toggle hides them (${st.colliders} shown)`);
}

const cases = { play: casePlay, fit: caseFit, clips: caseClips, pieces: casePieces, fix: caseFix, colliders: caseColliders };
if (!cases[caseName] || !dir) {
  console.error(`usage: page_tests.mjs ${Object.keys(cases).join('|')} DIR`);
  process.exit(2);
}
// A hung browser must not hang CTest: give up (and end chromium) after 150 s.
let browser = null;
const watchdog = setTimeout(() => {
  console.log('FAIL the page test did not finish within 150 s');
  if (browser) browser.child.kill('SIGKILL');
  process.exit(1);
}, 150000);
watchdog.unref();
browser = await Browser.launch(chromium);
const messages = browser.collectConsole();
try {
  await cases[caseName](browser);
} catch (e) {
  check(false, `${e.message}`);
} finally {
  await browser.close();
}
// Console: errors and exceptions fail, so do the page's own warnings; the browser's notes (e.g.
// the GL driver's "GPU stall due to ReadPixels" from the screenshots) are printed only.
for (const m of messages) console.log(`console ${m.level} (${m.source}): ${m.text.slice(0, 500)}`);
const bad = messages.filter((m) => m.level === 'error' || (m.level === 'warning' && (m.source === 'console' || m.source === 'exception')));
check(bad.length === 0, `no console error or page warning (${bad.length})`);
console.log(failures ? `${failures} checks failed` : 'all checks passed');
process.exit(failures ? 1 : 0);
