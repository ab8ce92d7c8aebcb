// skinspheres viewer: reads the page's data (#ss-data, "skinspheres.view" version 1, see
// docs/VIEWER.md) and the character (#ss-glb, base64 GLB), and shows the fit and the playback
// with three.js (THREE, THREE.GLTFLoader, THREE.OrbitControls from the scripts before this one).
//
// Per frame it draws the spheres where the runtime put them, the character posed at the clip time
// the runtime sampled, the sphere pairs owning the frame's triangle contacts (red spheres, and a
// red dot at the middle of each overlap), and, where the data has them, the intersecting
// triangles (magenta). Both contact colours are unlit and drawn over everything, so they are what
// the screen shows.
//
// For tests and links: URL hash parameters (see index.html), #ss-state's data-* attributes
// (ready, clip, frame, frames, pairs, triangle-pairs, selected, pieces, errors) and
// window.skinspheresViewer. A selected sphere's triangles are drawn on the surface, and its pieces of
// cut triangles (docs/TRIANGLE_PIECES.md) as sub-triangles skinned on the CPU.
(function () {
  'use strict';

  var CONTACT_COLOR = 0xff0000;   // sphere pairs in contact (markers: exactly this colour)
  var TRIANGLE_COLOR = 0xff00ff;  // intersecting triangles (exactly this colour)
  var OWNED_COLOR = 0x00d8ff;     // the selected sphere's triangles
  var PIECE_COLOR = 0x00ff80;     // the selected sphere's pieces of cut triangles
  var LOOSE_COLOR = 0xff9f1c;
  // Timeline marks: triangle contacts, penetrating (deeper than the run's touch tolerance) and
  // touching; sphere-only overlaps (broad-phase candidates, mostly no contact) when asked for.
  var PENETRATING_CSS = '#ff3b30', TOUCHING_CSS = '#ffb020';
  var PART_COLORS = { torso: 0x4e79a7, head: 0xedc948, arm_l: 0x59a14f, arm_r: 0x76b7b2, leg_l: 0xb07aa1, leg_r: 0x9c755f };
  var OTHER_COLORS = [0xbab0ac, 0xf28e2b, 0x86bcb6, 0xd4a6c8, 0x8cd17d, 0xa0cbe8, 0xfabfd2, 0xb6992d];

  function $(id) { return document.getElementById(id); }
  var stateEl = $('ss-state');
  function setState(key, value) { stateEl.setAttribute('data-' + key, String(value)); }
  function showMessage(text) { $('ss-message').textContent = text; }
  function fail(text) {
    setState('error', text);
    showMessage(text);
    console.error('skinspheres viewer: ' + text);
  }
  function fmt(x, digits) { return (x === null || x === undefined || !isFinite(x)) ? '\u2013' : Number(x).toFixed(digits); }
  function esc(s) {
    return String(s).replace(/[&<>"']/g, function (c) {
      return { '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;', "'": '&#39;' }[c];
    });
  }
  function bytesOfBase64(b64) {
    var bin = atob(b64.replace(/\s+/g, ''));
    var bytes = new Uint8Array(bin.length);
    for (var i = 0; i < bin.length; ++i) bytes[i] = bin.charCodeAt(i);
    return bytes;
  }
  function floatsOfBase64(b64) {
    var bytes = bytesOfBase64(b64);
    return new Float32Array(bytes.buffer, 0, bytes.length >> 2);
  }
  function uintsOfBase64(b64) {
    var bytes = bytesOfBase64(b64);
    return new Uint32Array(bytes.buffer, 0, bytes.length >> 2);
  }

  // ---------------------------------------------------------------------------------------------
  // Data

  var data;
  try {
    data = JSON.parse($('ss-data').textContent);
  } catch (e) {
    fail('the page data cannot be read: ' + e.message);
    return;
  }
  if (data.format !== 'skinspheres.view' || data.version !== 1) {
    fail('unknown page data format ' + data.format + ' version ' + data.version);
    return;
  }
  var sph = data.spheres;
  var S = sph.count;
  var restXyzr = floatsOfBase64(sph.rest_xyzr);
  var ownedOffsets = uintsOfBase64(sph.owned_offsets);
  var ownedTriangles = uintsOfBase64(sph.owned_triangles);
  var ownerOf = new Int32Array(data.character.triangles).fill(-1);  // triangle -> the sphere that owns it
  for (var o = 0; o < S; ++o) {
    for (var q = ownedOffsets[o]; q < ownedOffsets[o + 1]; ++q) ownerOf[ownedTriangles[q]] = o;
  }
  // Triangle pieces (docs/TRIANGLE_PIECES.md): sphere s owns pieces[3k..3k+2] = (triangle, level,
  // index) for k in [pieceOffsets[s], pieceOffsets[s + 1]).
  var pieceOffsets = sph.piece_offsets ? uintsOfBase64(sph.piece_offsets) : new Uint32Array(S + 1);
  var pieces = sph.pieces ? uintsOfBase64(sph.pieces) : new Uint32Array(0);
  var maxPieces = 0;
  for (o = 0; o < S; ++o) maxPieces = Math.max(maxPieces, pieceOffsets[o + 1] - pieceOffsets[o]);
  var metrics = data.metrics;
  var share = metrics && metrics.share ? floatsOfBase64(metrics.share) : new Float32Array(S);
  var loosest = metrics ? metrics.loosest : [];
  var clips = data.clips.map(function (c) {
    return {
      info: c,
      xyzr: floatsOfBase64(c.spheres_xyzr),
      frames: c.frames,
      partRows: null,  // built lazily: timeline rows
      action: null
    };
  });
  var excludedOf = [];  // per sphere: excluded partners
  for (var s = 0; s < S; ++s) excludedOf.push([]);
  var ex = sph.excluded.pairs;
  for (var k = 0; k + 1 < ex.length; k += 2) {
    excludedOf[ex[k]].push(ex[k + 1]);
    excludedOf[ex[k + 1]].push(ex[k]);
  }
  function partColor(p) {
    var name = sph.parts[p];
    return PART_COLORS.hasOwnProperty(name) ? PART_COLORS[name] : OTHER_COLORS[p % OTHER_COLORS.length];
  }

  // ---------------------------------------------------------------------------------------------
  // Scene

  var canvas = $('ss-canvas');
  var renderer;
  try {
    renderer = new THREE.WebGLRenderer({ canvas: canvas, antialias: true });
  } catch (e) {
    fail('WebGL is not available in this browser: ' + e.message);
    return;
  }
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.setClearColor(0x2a2d33);
  var scene = new THREE.Scene();
  var camera = new THREE.PerspectiveCamera(35, 1, 0.01, 1000);
  scene.add(camera);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x50545c, 0.75));
  var headlight = new THREE.DirectionalLight(0xffffff, 0.65);
  headlight.position.set(0.5, 1.0, 1.0);
  camera.add(headlight);
  var controls = new THREE.OrbitControls(camera, canvas);
  controls.enableKeys = false;

  // Bounds from the rest spheres (they cover the body).
  var lo = new THREE.Vector3(Infinity, Infinity, Infinity), hi = new THREE.Vector3(-Infinity, -Infinity, -Infinity);
  for (s = 0; s < S; ++s) {
    var r = restXyzr[4 * s + 3];
    lo.min(new THREE.Vector3(restXyzr[4 * s] - r, restXyzr[4 * s + 1] - r, restXyzr[4 * s + 2] - r));
    hi.max(new THREE.Vector3(restXyzr[4 * s] + r, restXyzr[4 * s + 1] + r, restXyzr[4 * s + 2] + r));
  }
  if (S === 0) { lo.set(-1, 0, -1); hi.set(1, 2, 1); }
  var center = lo.clone().add(hi).multiplyScalar(0.5);
  var extent = hi.clone().sub(lo);
  var size = Math.max(extent.x, extent.y, extent.z, 1e-6);
  camera.near = size / 100;
  camera.far = size * 100;

  function setView(dir) {
    var d = size / (2 * Math.tan(THREE.Math.degToRad(camera.fov / 2))) * 1.25;
    var offsets = { front: [0, 0, 1], back: [0, 0, -1], side: [1, 0, 0], top: [0, 1, 0.0001] };
    var o = offsets[dir] || offsets.front;
    controls.target.copy(center);
    camera.position.set(center.x + o[0] * d, center.y + o[1] * d, center.z + o[2] * d);
    camera.updateProjectionMatrix();
    controls.update();
    requestRender();
  }

  // Spheres: one mesh each (shared geometry), translucent, coloured by part or looseness.
  var sphereGeometry = new THREE.SphereBufferGeometry(1, 24, 16);
  var wireGeometry = new THREE.SphereBufferGeometry(1, 12, 8);
  var partMaterials = sph.parts.map(function (name, p) {
    return new THREE.MeshLambertMaterial({ color: partColor(p), transparent: true, opacity: 0.3, depthWrite: false });
  });
  var maxShare = 0;
  for (s = 0; s < S; ++s) maxShare = Math.max(maxShare, share[s]);
  var looseMaterials = [];
  for (s = 0; s < S; ++s) {
    var u = maxShare > 0 ? share[s] / maxShare : 0;
    var c = new THREE.Color().setHSL(0.6 - 0.55 * u, 0.75, 0.5);
    looseMaterials.push(new THREE.MeshLambertMaterial({ color: c, transparent: true, opacity: 0.3, depthWrite: false }));
  }
  var contactMaterial = new THREE.MeshLambertMaterial({ color: CONTACT_COLOR, emissive: 0x400000, transparent: true, opacity: 0.42, depthWrite: false });
  var sphereGroup = new THREE.Group();
  scene.add(sphereGroup);
  var sphereMeshes = [];
  for (s = 0; s < S; ++s) {
    var m = new THREE.Mesh(sphereGeometry, partMaterials[sph.part[s]]);
    m.userData.sphere = s;
    m.renderOrder = 2;
    sphereGroup.add(m);
    sphereMeshes.push(m);
  }
  var looseGroup = new THREE.Group();
  scene.add(looseGroup);
  var looseMeshes = loosest.map(function (id) {
    var w = new THREE.Mesh(wireGeometry, new THREE.MeshBasicMaterial({ color: LOOSE_COLOR, wireframe: true }));
    w.userData.sphere = id;
    w.renderOrder = 3;
    looseGroup.add(w);
    return w;
  });
  var selectedMesh = new THREE.Mesh(wireGeometry, new THREE.MeshBasicMaterial({ color: 0xffffff, wireframe: true, depthTest: false }));
  selectedMesh.renderOrder = 5;
  selectedMesh.visible = false;
  scene.add(selectedMesh);

  // Colliders (`colliders --html`, data.colliders): one mesh per shape, built about +Y from its head
  // (y = 0) to its tail (y = length): a lathe of the two balls' arcs joined by the cone between them.
  // Placed every frame from data.colliders (head and tail, world space, per clip and frame; `rest`
  // without a clip), coloured by the share of its vertices covered over the poses.
  var col = data.colliders || null;
  var colliderGroup = new THREE.Group();
  scene.add(colliderGroup);
  var colliderMeshes = (col ? col.shapes : []).map(function (c) {
    var ra = c.head_radius, rb = c.tail_radius, len = c.length, pts = [];
    var sinT = len > Math.abs(ra - rb) ? (ra - rb) / len : (ra >= rb ? 1 : -1), theta = Math.asin(sinT), i;
    for (i = 0; i <= 12; ++i) {
      var a1 = -Math.PI / 2 + (theta + Math.PI / 2) * i / 12;
      pts.push(new THREE.Vector2(ra * Math.cos(a1), ra * Math.sin(a1)));
    }
    for (i = 0; i <= 12; ++i) {
      var a2 = theta + (Math.PI / 2 - theta) * i / 12;
      pts.push(new THREE.Vector2(Math.max(rb * Math.cos(a2), 0), len + rb * Math.sin(a2)));
    }
    var colour = c.covered >= 0.999 ? 0x2e9e44 : (c.covered >= 0.97 ? 0xd9a400 : 0xd23c3c);
    var mesh = new THREE.Mesh(new THREE.LatheBufferGeometry(pts, 24),
      new THREE.MeshLambertMaterial({ color: colour, transparent: true, opacity: 0.35, depthWrite: false }));
    mesh.renderOrder = 2;
    mesh.userData.collider = c;
    colliderGroup.add(mesh);
    return mesh;
  });
  var yAxis = new THREE.Vector3(0, 1, 0), colliderDir = new THREE.Vector3();
  function updateColliders() {
    setState('colliders', ui.colliders ? colliderMeshes.length : 0);
    if (!col) return;
    var at = ui.clip >= 0 ? col.clips[ui.clip][ui.frame] : col.rest;
    colliderMeshes.forEach(function (m, k) {
      m.position.set(at[6 * k], at[6 * k + 1], at[6 * k + 2]);
      colliderDir.set(at[6 * k + 3] - at[6 * k], at[6 * k + 4] - at[6 * k + 1], at[6 * k + 5] - at[6 * k + 2]);
      if (colliderDir.lengthSq() > 0) m.quaternion.setFromUnitVectors(yAxis, colliderDir.normalize());
    });
  }

  // Contact markers: one dot per sphere pair owning a contact, at the middle of the overlap.
  var maxPairs = 1;
  clips.forEach(function (c) {
    (c.info.contact_pairs || c.info.pairs).forEach(function (p) { maxPairs = Math.max(maxPairs, p.length / 2); });
  });
  var markerGeometry = new THREE.BufferGeometry();
  markerGeometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(3 * maxPairs), 3));
  markerGeometry.setDrawRange(0, 0);
  var markers = new THREE.Points(markerGeometry, new THREE.PointsMaterial({
    color: CONTACT_COLOR, size: 9, sizeAttenuation: false, depthTest: false, depthWrite: false }));
  markers.frustumCulled = false;
  markers.renderOrder = 10;
  scene.add(markers);

  // Excluded pairs: a segment between the centres, coloured by reason.
  var exCount = ex.length / 2;
  var exGeometry = new THREE.BufferGeometry();
  exGeometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(6 * Math.max(exCount, 1)), 3));
  var exColors = new Float32Array(6 * Math.max(exCount, 1));
  var reasonColors = [new THREE.Color(0x8d93a0), new THREE.Color(0x5fb0ff), new THREE.Color(0xffd166)];
  for (k = 0; k < exCount; ++k) {
    var rc = reasonColors[sph.excluded.reason[k]] || reasonColors[0];
    for (var e2 = 0; e2 < 2; ++e2) exColors.set([rc.r, rc.g, rc.b], 6 * k + 3 * e2);
  }
  exGeometry.setAttribute('color', new THREE.BufferAttribute(exColors, 3));
  exGeometry.setDrawRange(0, 2 * exCount);
  var excludedLines = new THREE.LineSegments(exGeometry, new THREE.LineBasicMaterial({ vertexColors: THREE.VertexColors, transparent: true, opacity: 0.7 }));
  excludedLines.frustumCulled = false;
  excludedLines.visible = false;
  excludedLines.renderOrder = 4;
  scene.add(excludedLines);

  // ---------------------------------------------------------------------------------------------
  // UI state

  var ui = {
    clip: clips.length ? 0 : -1,
    frame: 0,
    playing: false,
    speed: 1,
    mesh: data.colliders ? 'xray' : 'solid',  // colliders lie under the skin: seen through it
    spheres: !data.colliders,
    color: 'part',
    contacts: true,
    loosest: data.kind === 'fit' && !data.colliders,  // marked by default on the fit page; a toggle on playback
    colliders: !!data.colliders,
    excluded: false,
    overlaps: false,  // sphere-only overlaps on the timeline
    selected: -1,
    view: 'front'
  };
  var character = null;       // { root, meshes: [{object, range, highlight, sourceIndex}], mixer, actions }
  var characterMaterial = { solid: [], xray: [] };
  var renderPending = false;

  function requestRender() {
    if (renderPending) return;
    renderPending = true;
    requestAnimationFrame(renderNow);
  }

  // The spheres of the current frame: [x, y, z, r] of sphere s at offset 4 s.
  function currentXyzr() {
    if (ui.clip < 0) return restXyzr;
    var c = clips[ui.clip];
    return c.xyzr.subarray(4 * S * ui.frame, 4 * S * (ui.frame + 1));
  }
  // The broad phase's sphere pairs (candidates), and the pairs owning the frame's triangle contacts
  // (i <= j; i == j: two triangles of one sphere). Pages from before the contact rules on triangles
  // have no contact_pairs: their candidates stand in.
  function currentPairs() { return ui.clip < 0 ? [] : clips[ui.clip].info.pairs[ui.frame]; }
  function currentContactPairs() {
    if (ui.clip < 0) return [];
    var info = clips[ui.clip].info;
    return info.contact_pairs ? info.contact_pairs[ui.frame] : info.pairs[ui.frame];
  }
  // The current frame's part pairs with triangle contacts: flat [part_a, part_b, kind, depth, ...],
  // kind 1 penetrating, 0 touching (null in pages from before the classification).
  function currentPartContacts() {
    if (ui.clip < 0) return null;
    var p = clips[ui.clip].info.part_contacts;
    return p ? p[ui.frame] : null;
  }
  function currentTrianglePairs() {
    if (ui.clip < 0) return null;
    var t = clips[ui.clip].info.triangle_pairs;
    return t ? t[ui.frame] : null;
  }

  // ---------------------------------------------------------------------------------------------
  // Character (GLB)

  function meshRangeOf(object) {
    var name = object.userData && object.userData.name;
    var ranges = data.character.meshes;
    for (var i = 0; i < ranges.length; ++i) {
      if (ranges[i].node === name) return i;
    }
    return -1;
  }

  function setupCharacter(gltf) {
    var root = gltf.scene;
    var meshes = [];
    root.traverse(function (o) {
      if (!o.isMesh) return;
      var index = meshRangeOf(o);
      o.frustumCulled = false;  // bounds are the bind pose's; animated poses leave them
      var solid = new THREE.MeshStandardMaterial({ color: 0xc8c0b6, roughness: 0.8, metalness: 0.0, skinning: !!o.isSkinnedMesh });
      var xray = new THREE.MeshStandardMaterial({ color: 0xc8c0b6, roughness: 0.8, metalness: 0.0, skinning: !!o.isSkinnedMesh,
        transparent: true, opacity: 0.35, depthWrite: false });
      characterMaterial.solid.push(solid);
      characterMaterial.xray.push(xray);
      o.userData.materials = { solid: solid, xray: xray };
      o.material = solid;
      o.renderOrder = 1;
      meshes.push({ object: o, range: index, highlight: null });
    });
    // Highlight meshes: the same vertex buffers and skeleton, an index buffer of some of the
    // mesh's triangles. `highlight`: the current frame's intersecting triangles, drawn over
    // everything; `owned`: the selected sphere's triangles, on the surface.
    function highlightMesh(o, triangles, material, renderOrder) {
      var g = new THREE.BufferGeometry();
      ['position', 'normal', 'skinIndex', 'skinWeight'].forEach(function (name) {
        var a = o.geometry.getAttribute(name);
        if (a) g.setAttribute(name, a);
      });
      g.setIndex(new THREE.BufferAttribute(new Uint32Array(3 * Math.max(triangles, 1)), 1));
      g.setDrawRange(0, 0);
      var h = o.isSkinnedMesh ? new THREE.SkinnedMesh(g, material) : new THREE.Mesh(g, material);
      if (o.isSkinnedMesh) h.bind(o.skeleton, o.bindMatrix);
      h.frustumCulled = false;
      h.renderOrder = renderOrder;
      h.visible = false;
      o.add(h);
      return h;
    }
    meshes.forEach(function (entry) {
      if (entry.range < 0) return;
      var o = entry.object;
      var triangles = data.character.meshes[entry.range].triangle_count;
      var skinning = !!o.isSkinnedMesh;
      entry.highlight = highlightMesh(o, triangles, new THREE.MeshBasicMaterial({ color: TRIANGLE_COLOR, side: THREE.DoubleSide,
        depthTest: false, depthWrite: false, skinning: skinning }), 9);
      entry.owned = highlightMesh(o, triangles, new THREE.MeshBasicMaterial({ color: OWNED_COLOR, side: THREE.DoubleSide,
        polygonOffset: true, polygonOffsetFactor: -1, polygonOffsetUnits: -4, skinning: skinning }), 1);
    });
    scene.add(root);
    var mixer = new THREE.AnimationMixer(root);
    var actions = {};
    gltf.animations.forEach(function (a) {
      var action = mixer.clipAction(a);
      action.setLoop(THREE.LoopOnce);
      action.clampWhenFinished = true;
      actions[a.name] = action;
    });
    character = { root: root, meshes: meshes, mixer: mixer, actions: actions };
    var missing = clips.filter(function (c) { return !actions[c.info.animation]; }).map(function (c) { return c.info.animation; });
    if (missing.length) fail('the character has no animation named ' + missing.join(', '));
    var unmatched = meshes.filter(function (e) { return e.range < 0; }).length;
    if (unmatched) fail(unmatched + ' meshes of the GLB match no mesh of the page data');
  }

  function poseCharacter() {
    if (!character) return;
    var mixer = character.mixer;
    mixer.stopAllAction();
    if (ui.clip >= 0) {
      var info = clips[ui.clip].info;
      var action = character.actions[info.animation];
      if (action) {
        action.reset();
        action.play();
        mixer.setTime(info.clip_time[ui.frame]);
      }
    }
    // Without a clip the nodes keep the file's own transforms: the rest pose the spheres were
    // fitted to (stopping the actions restores them; Skeleton.pose() would not: it ignores
    // non-bone parents such as a scaled armature node).
  }

  // Shows `triangles` (source triangle indices, any order, repeats allowed) on the highlight
  // meshes named `kind` ('highlight' or 'owned').
  function showTriangles(kind, triangles) {
    var perRange = {};
    var ranges = data.character.meshes;
    for (var i = 0; i < triangles.length; ++i) {
      var t = triangles[i];
      for (var r = 0; r < ranges.length; ++r) {
        if (t >= ranges[r].first_triangle && t < ranges[r].first_triangle + ranges[r].triangle_count) {
          (perRange[r] = perRange[r] || {})[t - ranges[r].first_triangle] = true;
          break;
        }
      }
    }
    character.meshes.forEach(function (entry) {
      var h = entry[kind];
      if (!h) return;
      var src = entry.object.geometry.index;
      var out = h.geometry.index.array;
      var n = 0;
      Object.keys(perRange[entry.range] || {}).forEach(function (key) {
        var local = Number(key);
        for (var v = 0; v < 3; ++v) out[3 * n + v] = src ? src.array[3 * local + v] : 3 * local + v;
        ++n;
      });
      h.geometry.index.needsUpdate = true;
      h.geometry.setDrawRange(0, 3 * n);
      h.visible = n > 0;
    });
  }

  // The grid coordinates (i, j) of piece `index` of a level-L grid, in the runtime's order
  // (sphere_set.h, PieceCorners): upward pieces row by row, then downward ones.
  function pieceCorners(level, index) {
    var up = level * (level + 1) / 2, upward = index < up, k = upward ? index : index - up, j = 0;
    for (var row = upward ? level : level - 1; k >= row; --row) { k -= row; ++j; }
    return upward ? [[k, j], [k + 1, j], [k, j + 1]] : [[k + 1, j], [k + 1, j + 1], [k, j + 1]];
  }

  // Vertex i of mesh object o, skinned on the CPU as three.js skins it on the GPU, in world space.
  var skinTmp = { v: new THREE.Vector3(), t: new THREE.Vector3(), m: new THREE.Matrix4() };
  function skinnedVertex(o, i, out) {
    var g = o.geometry;
    out.fromBufferAttribute(g.getAttribute('position'), i);
    if (o.isSkinnedMesh) {
      var si = g.getAttribute('skinIndex'), sw = g.getAttribute('skinWeight'), bones = o.skeleton.bones;
      var bound = skinTmp.v.copy(out).applyMatrix4(o.bindMatrix);
      out.set(0, 0, 0);
      var index = [si.getX(i), si.getY(i), si.getZ(i), si.getW(i)], weight = [sw.getX(i), sw.getY(i), sw.getZ(i), sw.getW(i)];
      for (var k = 0; k < 4; ++k) {
        if (weight[k] === 0) continue;
        skinTmp.m.multiplyMatrices(bones[index[k]].matrixWorld, o.skeleton.boneInverses[index[k]]);
        out.add(skinTmp.t.copy(bound).applyMatrix4(skinTmp.m).multiplyScalar(weight[k]));
      }
      out.applyMatrix4(o.bindMatrixInverse);
    }
    return out.applyMatrix4(o.matrixWorld);
  }

  // The selected sphere's pieces, each a sub-triangle of its skinned triangle, drawn in world space.
  var pieceMesh = null;
  function showPieces() {
    var first = ui.selected >= 0 && ui.mesh !== 'off' ? pieceOffsets[ui.selected] : 0;
    var last = ui.selected >= 0 && ui.mesh !== 'off' ? pieceOffsets[ui.selected + 1] : 0;
    if (!pieceMesh && maxPieces > 0) {
      var g = new THREE.BufferGeometry();
      g.setAttribute('position', new THREE.BufferAttribute(new Float32Array(9 * maxPieces), 3));
      pieceMesh = new THREE.Mesh(g, new THREE.MeshBasicMaterial({ color: PIECE_COLOR, side: THREE.DoubleSide,
        polygonOffset: true, polygonOffsetFactor: -1, polygonOffsetUnits: -4 }));
      pieceMesh.frustumCulled = false;
      pieceMesh.renderOrder = 1;
      scene.add(pieceMesh);
    }
    var n = 0;
    if (last > first) {
      character.root.updateMatrixWorld(true);
      var pos = pieceMesh.geometry.getAttribute('position'), ranges = data.character.meshes;
      var p = [new THREE.Vector3(), new THREE.Vector3(), new THREE.Vector3()], c = new THREE.Vector3();
      for (var k = first; k < last; ++k) {
        var t = pieces[3 * k], level = pieces[3 * k + 1], index = pieces[3 * k + 2];
        var entry = null;
        for (var e = 0; e < character.meshes.length && !entry; ++e) {
          var r = character.meshes[e].range;
          if (r >= 0 && t >= ranges[r].first_triangle && t < ranges[r].first_triangle + ranges[r].triangle_count) entry = character.meshes[e];
        }
        if (!entry) continue;
        var local = t - ranges[entry.range].first_triangle, src = entry.object.geometry.index;
        for (var v = 0; v < 3; ++v) skinnedVertex(entry.object, src ? src.array[3 * local + v] : 3 * local + v, p[v]);
        var corners = pieceCorners(level, index);
        for (v = 0; v < 3; ++v) {
          var i = corners[v][0], j = corners[v][1];
          c.copy(p[0]).multiplyScalar((level - i - j) / level).addScaledVector(p[1], i / level).addScaledVector(p[2], j / level);
          pos.setXYZ(3 * n + v, c.x, c.y, c.z);
        }
        ++n;
      }
      pos.needsUpdate = true;
    }
    if (pieceMesh) {
      pieceMesh.geometry.setDrawRange(0, 3 * n);
      pieceMesh.visible = n > 0;
    }
    setState('pieces', n);
  }

  function updateTriangleHighlights() {
    if (!character) return;
    showPieces();
    var pairs = ui.contacts ? currentTrianglePairs() : null;
    showTriangles('highlight', pairs || []);
    setState('triangle-pairs', pairs ? pairs.length / 2 : 0);
    showTriangles('owned', ui.selected >= 0 && ui.mesh !== 'off' ? ownedTriangles.subarray(ownedOffsets[ui.selected], ownedOffsets[ui.selected + 1]) : []);
  }

  // ---------------------------------------------------------------------------------------------
  // Frame update

  function updateFrame() {
    var xyzr = currentXyzr();
    var pairs = ui.contacts ? currentContactPairs() : [];
    var inContact = new Uint8Array(S);
    for (var i = 0; i + 1 < pairs.length; i += 2) { inContact[pairs[i]] = 1; inContact[pairs[i + 1]] = 1; }
    for (var s2 = 0; s2 < S; ++s2) {
      var m2 = sphereMeshes[s2];
      m2.position.set(xyzr[4 * s2], xyzr[4 * s2 + 1], xyzr[4 * s2 + 2]);
      m2.scale.setScalar(Math.max(xyzr[4 * s2 + 3], 1e-9));
      m2.material = inContact[s2] ? contactMaterial : (ui.color === 'loose' ? looseMaterials[s2] : partMaterials[sph.part[s2]]);
    }
    looseMeshes.forEach(function (w) {
      var id = w.userData.sphere;
      w.position.copy(sphereMeshes[id].position);
      w.scale.copy(sphereMeshes[id].scale).multiplyScalar(1.004);
    });
    // Markers at the middle of each overlap: c_i + d (r_i - overlap / 2), d the unit direction i -> j.
    var pos = markerGeometry.getAttribute('position');
    var n = 0;
    for (i = 0; i + 1 < pairs.length; i += 2) {
      var a = pairs[i], b = pairs[i + 1];
      var ax = xyzr[4 * a], ay = xyzr[4 * a + 1], az = xyzr[4 * a + 2], ar = xyzr[4 * a + 3];
      var dx = xyzr[4 * b] - ax, dy = xyzr[4 * b + 1] - ay, dz = xyzr[4 * b + 2] - az;
      var d = Math.sqrt(dx * dx + dy * dy + dz * dz);
      var along = d > 0 ? (ar - (ar + xyzr[4 * b + 3] - d) / 2) / d : 0;
      pos.setXYZ(n++, ax + dx * along, ay + dy * along, az + dz * along);
    }
    pos.needsUpdate = true;
    markerGeometry.setDrawRange(0, n);
    if (ui.excluded) {
      var ep = exGeometry.getAttribute('position');
      for (k = 0; k < exCount; ++k) {
        var p = ex[2 * k], q = ex[2 * k + 1];
        ep.setXYZ(2 * k, xyzr[4 * p], xyzr[4 * p + 1], xyzr[4 * p + 2]);
        ep.setXYZ(2 * k + 1, xyzr[4 * q], xyzr[4 * q + 1], xyzr[4 * q + 2]);
      }
      ep.needsUpdate = true;
    }
    if (ui.selected >= 0) {
      selectedMesh.position.copy(sphereMeshes[ui.selected].position);
      selectedMesh.scale.copy(sphereMeshes[ui.selected].scale).multiplyScalar(1.01);
    }
    updateColliders();
    poseCharacter();
    updateTriangleHighlights();
    updateFrameUi(ui.contacts ? currentPairs() : []);
    setState('clip', ui.clip >= 0 ? clips[ui.clip].info.name : '');
    setState('frame', ui.frame);
    setState('pairs', pairs.length / 2);
    requestRender();
  }

  function applyVisibility() {
    sphereGroup.visible = ui.spheres;
    looseGroup.visible = ui.loosest;
    colliderGroup.visible = ui.colliders;
    markers.visible = ui.contacts;
    excludedLines.visible = ui.excluded;
    if (character) {
      character.meshes.forEach(function (e) {
        // Hidden through its material, not the object: its highlight children stay visible.
        var mats = e.object.userData.materials;
        mats.solid.visible = mats.xray.visible = ui.mesh !== 'off';
        e.object.material = mats[ui.mesh === 'xray' ? 'xray' : 'solid'];
      });
    }
    updateFrame();
  }

  // ---------------------------------------------------------------------------------------------
  // Panels

  function partPairName(a, b) { return sph.parts[a] + ' \u2013 ' + sph.parts[b]; }

  function updateFrameUi(pairs) {
    var label = $('ss-frame-label');
    if (ui.clip < 0) {
      label.textContent = data.clips.length ? '' : (data.character.clips.length ? 'bind pose (fit only)' : 'bind pose (no clip)');
    } else {
      var info = clips[ui.clip].info;
      label.textContent = 'frame ' + ui.frame + ' / ' + (info.frames - 1) + '   t = ' + fmt(info.time[ui.frame], 2) + ' s';
      $('ss-frame').value = ui.frame;
    }
    // Contacts this frame, grouped by part pair.
    var groups = {};
    var depths = ui.clip >= 0 ? clips[ui.clip].info.depths[ui.frame] : [];
    for (var i = 0; i + 1 < pairs.length; i += 2) {
      var a = sph.part[pairs[i]], b = sph.part[pairs[i + 1]];
      var key = Math.min(a, b) + ',' + Math.max(a, b);
      var g = groups[key] = groups[key] || { a: Math.min(a, b), b: Math.max(a, b), n: 0, depth: 0, spheres: [] };
      g.n++;
      g.depth = Math.max(g.depth, depths[i / 2] || 0);
      g.spheres.push(pairs[i], pairs[i + 1]);
    }
    var keys = Object.keys(groups);
    var tri = currentTrianglePairs();
    var parts = currentPartContacts();
    var height = data.metrics && data.metrics.body_height > 0 ? data.metrics.body_height : 0;
    var html = '';
    if (parts && parts.length) {
      html += '<table>';
      for (var k2 = 0; k2 + 3 < parts.length; k2 += 4) {
        var pen = parts[k2 + 2] === 1, depth = parts[k2 + 3];
        html += '<tr><td>' + esc(partPairName(parts[k2], parts[k2 + 1])) + '</td><td class="num ' + (pen ? 'pen' : 'touch') + '">' +
          (pen ? 'penetrating' : 'touching') + (depth > 0 ? ', ' + (height ? fmt(100 * depth / height, 2) + '% of height' : fmt(depth, 4)) : '') +
          '</td></tr>';
      }
      html += '</table>';
    } else if (parts) {
      html += '<span class="muted">no triangle contact</span>';
    }
    if (keys.length) {
      html += '<div class="muted">sphere overlaps (candidates):</div><table>' + keys.map(function (key) {
        var g2 = groups[key];
        return '<tr><td>' + esc(partPairName(g2.a, g2.b)) + '</td><td class="num">' + g2.n + ' sphere pair' + (g2.n > 1 ? 's' : '') +
          ', overlap up to ' + fmt(g2.depth, 4) + '</td></tr>';
      }).join('') + '</table>';
    } else if (!parts) {
      html += '<span class="muted">none</span>';
    }
    if (tri) html += '<div class="num">' + (tri.length / 2) + ' intersecting triangle pairs</div>';
    $('ss-now-body').innerHTML = html;
    updateTimelineHead();
    updatePickPanel();
  }

  function updatePickPanel() {
    var body = $('ss-pick-body');
    setState('selected', ui.selected);
    selectedMesh.visible = ui.selected >= 0;
    if (ui.selected < 0) {
      body.innerHTML = '<span class="muted">click a sphere</span>';
      return;
    }
    var s3 = ui.selected;
    var xyzr = currentXyzr();
    var partners = [];
    var pairs = currentContactPairs();
    for (var i = 0; i + 1 < pairs.length; i += 2) {
      if (pairs[i] === s3 && pairs[i + 1] !== s3) partners.push(pairs[i + 1]);
      if (pairs[i + 1] === s3 && pairs[i] !== s3) partners.push(pairs[i]);
    }
    var rows = [
      ['id', s3],
      ['part', esc(sph.parts[sph.part[s3]])],
      ['joint', esc(sph.joint_names[sph.joint[s3]])],
      ['level', sph.level[s3]],
      ['radius', fmt(xyzr[4 * s3 + 3], 4) + (ui.clip >= 0 ? ' (rest ' + fmt(restXyzr[4 * s3 + 3], 4) + ')' : '')],
      ['triangles', sph.triangles[s3] + ' <span class="muted">(shown on the mesh)</span>'],
      ['vertices', sph.vertices[s3]],
      ['looseness', metrics ? fmt(100 * share[s3], 1) + '% of the boundary distance' : '\u2013'],
      ['excluded with', excludedOf[s3].length + ' spheres'],
      ['touching', partners.length ? partners.map(function (p) { return '<span class="link" data-sphere="' + p + '">#' + p + '</span>'; }).join(' ') : 'none']
    ];
    body.innerHTML = '<table>' + rows.map(function (r2) { return '<tr><td>' + r2[0] + '</td><td class="num">' + r2[1] + '</td></tr>'; }).join('') + '</table>';
  }

  function fillStaticPanels() {
    var ch = data.character;
    $('ss-file').textContent = ch.file;
    document.title = 'skinspheres: ' + ch.file;
    var facts = [
      '<span><b>' + ch.vertices + '</b> vertices, <b>' + ch.triangles + '</b> triangles, <b>' + ch.joints + '</b> joints</span>',
      '<span><b>' + S + '</b> spheres in <b>' + sph.parts.length + '</b> parts, ' + (ex.length / 2) + ' excluded pairs</span>'
    ];
    if (metrics) {
      facts.push('<span>union / body volume <b>' + fmt(metrics.volume_ratio, 2) + '</b></span>');
      facts.push('<span>boundary distance mean <b>' + fmt(100 * metrics.boundary_mean_rel, 2) + '%</b>, max <b>' +
        fmt(100 * metrics.boundary_max_rel, 2) + '%</b> of height</span>');
      if (metrics.uncovered_triangles) facts.push('<span class="note">' + metrics.uncovered_triangles + ' uncovered triangles</span>');
    }
    var t = data.timings;
    facts.push('<span>import <b>' + fmt(t.import_ms, 1) + '</b> ms' + (t.fit_ms !== null ? ', fit <b>' + fmt(t.fit_ms, 1) + '</b> ms' : ', spheres from a file') + '</span>');
    facts.push('<span id="ss-stage-fact"></span>');
    (data.notes || []).forEach(function (n2) { facts.push('<span class="note">' + esc(n2) + '</span>'); });
    $('ss-facts').innerHTML = facts.join('');

    var legend = sph.parts.map(function (name, p) {
      return '<span><span class="swatch" style="background:#' + new THREE.Color(partColor(p)).getHexString() + '"></span>' + esc(name) + '</span>';
    });
    legend.push('<span><span class="swatch" style="background:#ff0000"></span>sphere pair</span>');
    if (clips.some(function (c) { return c.info.triangle_pairs; })) {
      legend.push('<span><span class="swatch" style="background:#ff00ff"></span>intersecting triangles</span>');
    }
    if (clips.some(function (c) { return c.info.part_contacts; })) {
      legend.push('<span><span class="swatch" style="background:' + PENETRATING_CSS + '"></span>penetrating</span>');
      legend.push('<span><span class="swatch" style="background:' + TOUCHING_CSS + '"></span>touching (timeline)</span>');
    }
    if (loosest.length) legend.push('<span><span class="swatch" style="background:#ff9f1c"></span>loosest</span>');
    $('ss-legend').innerHTML = legend.join('');

    $('ss-loose-body').innerHTML = loosest.length ? '<table>' + loosest.map(function (id) {
      return '<tr><td><span class="link" data-sphere="' + id + '">#' + id + '</span></td><td>' + esc(sph.parts[sph.part[id]]) + ' / ' +
        esc(sph.joint_names[sph.joint[id]]) + ', ' + fmt(100 * share[id], 1) + '%</td></tr>';
    }).join('') + '</table><div class="muted">largest shares of the mean boundary distance</div>' : '<span class="muted">no metrics</span>';

    var rows = [];
    if (metrics) rows.push('<tr><td>metrics</td><td class="num">' + fmt(t.metrics_ms, 1) + ' ms</td></tr>');
    clips.forEach(function (c) {
      var info = c.info;
      rows.push('<tr><td class="name" title="' + esc(info.name) + '">' + esc(info.name) + '</td><td class="num">' + info.frames + ' frames at ' + fmt(info.fps, 0) + ' fps, ' + info.mode + ' refit</td></tr>');
      ['sample', 'skin', 'refit', 'query', 'narrow'].forEach(function (stage) {
        var st = info.stages_us[stage];
        if (st) rows.push('<tr><td>&nbsp;&nbsp;' + stage + '</td><td class="num">median ' + fmt(st.median_us, 1) + ' &micro;s, p95 ' + fmt(st.p95_us, 1) + ' &micro;s</td></tr>');
      });
    });
    rows.push('<tr><td>three.js</td><td>r' + esc(data.three_revision) + ' (MIT)</td></tr>');
    $('ss-times-body').innerHTML = '<table>' + rows.join('') + '</table>';

    var select = $('ss-clip');
    select.innerHTML = clips.length ? clips.map(function (c, i) { return '<option value="' + i + '">' + esc(c.info.name) + '</option>'; }).join('')
                                    : '<option>no clip</option>';
    if (!clips.length) $('ss-transport').classList.add('disabled');
  }

  // ---------------------------------------------------------------------------------------------
  // Timeline: one row per part pair with triangle contacts in the clip; marks on its frames:
  // penetrating and touching (two colours, from part_contacts), intersecting triangles of pages
  // without that classification (magenta), and, when asked for, sphere-only overlaps (grey:
  // broad-phase candidates, which mostly are no contact).

  function buildTimeline() {
    var el = $('ss-timeline');
    if (ui.clip < 0) {
      el.innerHTML = '<div class="empty">' + (clips.length ? '' : 'no clip played: the bind pose of the fit') + '</div>';
      return;
    }
    var c = clips[ui.clip];
    var info = c.info;
    var F = info.frames;
    var rows = {};
    function mark(a, b, f, kind) {
      var lo = Math.min(a, b), hi = Math.max(a, b), key = lo + ',' + hi;
      var row = rows[key] = rows[key] || { a: lo, b: hi, sphere: new Uint8Array(F), pen: new Uint8Array(F), touch: new Uint8Array(F), tri: new Uint8Array(F) };
      row[kind][f] = 1;
    }
    for (var f = 0; f < F; ++f) {
      var pairs = info.pairs[f];
      for (var i = 0; i + 1 < pairs.length; i += 2) mark(sph.part[pairs[i]], sph.part[pairs[i + 1]], f, 'sphere');
      var pc = info.part_contacts ? info.part_contacts[f] : [];
      for (i = 0; i + 3 < pc.length; i += 4) mark(pc[i], pc[i + 1], f, pc[i + 2] === 1 ? 'pen' : 'touch');
    }
    var tri = info.triangle_pairs;
    if (tri) {
      // Intersecting triangle pairs on frames the classification does not cover (older pages, or
      // pairs added to the data) land on the row of their owners' parts.
      for (f = 0; f < F; ++f) {
        var tp = tri[f];
        for (i = 0; i + 1 < tp.length; i += 2) {
          var sa = ownerOf[tp[i]], sb = ownerOf[tp[i + 1]];
          if (sa < 0 || sb < 0) continue;
          var a = sph.part[sa], b = sph.part[sb], row = rows[Math.min(a, b) + ',' + Math.max(a, b)];
          if (!row || (!row.pen[f] && !row.touch[f])) mark(a, b, f, 'tri');
        }
      }
    }
    var keys = Object.keys(rows).filter(function (key) {
      var r = rows[key];
      return ui.overlaps || r.pen.some(Boolean) || r.touch.some(Boolean) || r.tri.some(Boolean);
    }).sort(function (x, y) {
      var p = x.split(',').map(Number), q = y.split(',').map(Number);
      return p[0] - q[0] || p[1] - q[1];
    });
    var html = '';
    keys.forEach(function (key) {
      var row = rows[key];
      html += '<div class="row" data-parts="' + esc(sph.parts[row.a] + ',' + sph.parts[row.b]) + '"><div class="label">' +
        esc(partPairName(row.a, row.b)) + '</div><div class="track">' + (ui.overlaps ? runs(row.sphere, F, ' sph') : '') +
        runs(row.touch, F, ' touch') + runs(row.pen, F, ' pen') + runs(row.tri, F, ' tri') + '</div></div>';
    });
    var hidden = Object.keys(rows).length - keys.length;
    el.innerHTML = (html || '<div class="empty">no triangle contact in this clip' +
      (hidden ? ' (' + hidden + ' part pairs with sphere overlaps only: "sphere overlaps" shows them)' : '') + '</div>') +
      '<div class="head"></div>';
    setState('timeline-rows', keys.length);
    updateTimelineHead();
  }

  // Consecutive frames as one mark element (data-first / data-last); a click picks the frame under it.
  function runs(flags, F, cls) {
    var out = '';
    for (var f = 0; f < F;) {
      if (!flags[f]) { ++f; continue; }
      var e = f;
      while (e + 1 < F && flags[e + 1]) ++e;
      out += '<span class="mark' + cls + '" data-first="' + f + '" data-last="' + e + '" style="left:' + (100 * f / F) + '%;width:' +
        (100 * (e - f + 1) / F) + '%"></span>';
      f = e + 1;
    }
    return out;
  }

  function updateTimelineHead() {
    var head = document.querySelector('#ss-timeline .head');
    var track = document.querySelector('#ss-timeline .track');
    if (!head || !track || ui.clip < 0) return;
    var F = clips[ui.clip].info.frames;
    var host = $('ss-timeline').getBoundingClientRect();
    var t = track.getBoundingClientRect();
    head.style.left = (t.left - host.left + (ui.frame + 0.5) / F * t.width) + 'px';
  }

  $('ss-timeline').addEventListener('click', function (ev) {
    if (ui.clip < 0) return;
    var track = ev.target.closest('.track');
    if (!track) return;
    var F = clips[ui.clip].info.frames;
    var t = track.getBoundingClientRect();
    var f = Math.floor((ev.clientX - t.left) / t.width * F);
    var mark = ev.target.closest('.mark');
    if (mark) {  // on a mark: a frame of that mark
      f = Math.min(Math.max(f, Number(mark.dataset.first)), Number(mark.dataset.last));
    }
    setPlaying(false);
    setFrame(f);
  });

  // ---------------------------------------------------------------------------------------------
  // Controls

  function setFrame(f) {
    if (ui.clip < 0) return;
    var F = clips[ui.clip].info.frames;
    ui.frame = Math.min(Math.max(Math.round(f) || 0, 0), F - 1);
    updateFrame();
    saveHash();
  }
  function setClip(index) {
    if (index < 0 || index >= clips.length) return;
    ui.clip = index;
    $('ss-clip').value = String(index);
    var frame = $('ss-frame');
    frame.max = String(clips[index].info.frames - 1);
    ui.frame = Math.min(ui.frame, clips[index].info.frames - 1);
    playClock = ui.frame / clips[index].info.fps;
    buildTimeline();
    var st = clips[index].info.stages_us;
    $('ss-stage-fact').innerHTML = 'per frame (' + esc(clips[index].info.name) + ', medians): ' + ['sample', 'skin', 'refit', 'query', 'narrow'].filter(function (name) {
      return name !== 'narrow' || st[name];  // pages from before the narrow phase have no such stage
    }).map(function (name) {
      return name + ' <b>' + fmt(st[name] ? st[name].median_us : null, 1) + '</b>';
    }).join(', ') + ' &micro;s';
    updateFrame();
  }
  function setPlaying(on) {
    ui.playing = on && ui.clip >= 0;
    $('ss-play').innerHTML = ui.playing ? '&#10074;&#10074;' : '&#9654;';
    if (ui.playing) {
      playClock = ui.frame / clips[ui.clip].info.fps;
      lastTick = performance.now();
      requestRender();
    }
  }
  function select(id) {
    ui.selected = (id >= 0 && id < S) ? id : -1;
    updateFrame();
    saveHash();
  }

  $('ss-clip').addEventListener('change', function () { setClip(Number(this.value)); saveHash(); });
  $('ss-play').addEventListener('click', function () { setPlaying(!ui.playing); });
  $('ss-step').addEventListener('click', function () { setPlaying(false); setFrame(ui.frame + 1); });
  $('ss-step-back').addEventListener('click', function () { setPlaying(false); setFrame(ui.frame - 1); });
  $('ss-frame').addEventListener('input', function () { setPlaying(false); setFrame(Number(this.value)); });
  $('ss-speed').addEventListener('change', function () { ui.speed = Number(this.value); });
  $('ss-mesh').addEventListener('change', function () { ui.mesh = this.value; applyVisibility(); saveHash(); });
  $('ss-spheres').addEventListener('change', function () { ui.spheres = this.checked; applyVisibility(); saveHash(); });
  $('ss-color').addEventListener('change', function () { ui.color = this.value; applyVisibility(); saveHash(); });
  $('ss-contacts').addEventListener('change', function () { ui.contacts = this.checked; applyVisibility(); saveHash(); });
  $('ss-loosest').addEventListener('change', function () { ui.loosest = this.checked; applyVisibility(); saveHash(); });
  $('ss-excluded').addEventListener('change', function () { ui.excluded = this.checked; applyVisibility(); saveHash(); });
  $('ss-colliders').addEventListener('change', function () { ui.colliders = this.checked; applyVisibility(); saveHash(); });
  if (!data.colliders) $('ss-colliders-label').style.display = 'none';
  $('ss-overlaps').addEventListener('change', function () { ui.overlaps = this.checked; buildTimeline(); saveHash(); });
  $('ss-viewdir').addEventListener('change', function () { ui.view = this.value; setView(ui.view); });
  document.addEventListener('click', function (ev) {
    var link = ev.target.closest && ev.target.closest('[data-sphere]');
    if (link) select(Number(link.dataset.sphere));
  });
  document.addEventListener('keydown', function (ev) {
    if (ev.target.tagName === 'INPUT' || ev.target.tagName === 'SELECT') return;
    if (ev.key === ' ') { setPlaying(!ui.playing); ev.preventDefault(); }
    if (ev.key === 'ArrowRight') { setPlaying(false); setFrame(ui.frame + 1); }
    if (ev.key === 'ArrowLeft') { setPlaying(false); setFrame(ui.frame - 1); }
  });

  // Picking: a click (not a drag) on a visible sphere selects the nearest one under the pointer.
  var raycaster = new THREE.Raycaster();
  var downAt = null;
  canvas.addEventListener('pointerdown', function (ev) { downAt = [ev.clientX, ev.clientY]; });
  canvas.addEventListener('pointerup', function (ev) {
    if (!downAt || Math.abs(ev.clientX - downAt[0]) + Math.abs(ev.clientY - downAt[1]) > 4) return;
    downAt = null;
    if (!ui.spheres) return;
    var rect = canvas.getBoundingClientRect();
    var ndc = new THREE.Vector2((ev.clientX - rect.left) / rect.width * 2 - 1, -(ev.clientY - rect.top) / rect.height * 2 + 1);
    raycaster.setFromCamera(ndc, camera);
    var hits = raycaster.intersectObjects(sphereMeshes, false);
    select(hits.length ? hits[0].object.userData.sphere : -1);
  });

  // ---------------------------------------------------------------------------------------------
  // Hash parameters

  function readHash() {
    var params = {};
    location.hash.replace(/^#/, '').split('&').forEach(function (kv) {
      if (!kv) return;
      var i = kv.indexOf('=');
      params[decodeURIComponent(i < 0 ? kv : kv.slice(0, i))] = i < 0 ? '1' : decodeURIComponent(kv.slice(i + 1));
    });
    return params;
  }
  function applyHash() {
    var p = readHash();
    if (p.clip !== undefined && clips.length) {
      var idx = clips.findIndex(function (c) { return c.info.name === p.clip; });
      if (idx < 0 && /^\d+$/.test(p.clip)) idx = Number(p.clip);
      if (idx >= 0 && idx < clips.length) ui.clip = idx;
    }
    if (p.frame !== undefined) ui.frame = Number(p.frame) || 0;
    if (p.mesh !== undefined) ui.mesh = ['solid', 'xray', 'off'].indexOf(p.mesh) >= 0 ? p.mesh : 'solid';
    if (p.spheres !== undefined) ui.spheres = p.spheres !== '0';
    if (p.contacts !== undefined) ui.contacts = p.contacts !== '0';
    if (p.loosest !== undefined) ui.loosest = p.loosest !== '0';
    if (p.excluded !== undefined) ui.excluded = p.excluded !== '0';
    if (p.colliders !== undefined) ui.colliders = !!data.colliders && p.colliders !== '0';
    if (p.overlaps !== undefined) ui.overlaps = p.overlaps !== '0';
    if (p.color !== undefined) ui.color = p.color === 'loose' ? 'loose' : 'part';
    if (p.sphere !== undefined) ui.selected = Number(p.sphere);
    if (p.speed !== undefined) ui.speed = Number(p.speed) || 1;
    if (p.view !== undefined) ui.view = p.view;
    $('ss-mesh').value = ui.mesh;
    $('ss-spheres').checked = ui.spheres;
    $('ss-contacts').checked = ui.contacts;
    $('ss-loosest').checked = ui.loosest;
    $('ss-excluded').checked = ui.excluded;
    $('ss-colliders').checked = ui.colliders;
    $('ss-overlaps').checked = ui.overlaps;
    $('ss-color').value = ui.color;
    $('ss-viewdir').value = ui.view;
    if (!(ui.selected >= 0 && ui.selected < S)) ui.selected = -1;
    if (ui.clip >= 0) {
      var frame = ui.frame;
      setClip(ui.clip);
      ui.frame = Math.min(Math.max(Math.round(frame), 0), clips[ui.clip].info.frames - 1);
    }
    setView(ui.view);
    applyVisibility();
    setPlaying(p.play === '1');
  }
  function saveHash() {
    var parts = [];
    if (ui.clip >= 0) parts.push('clip=' + encodeURIComponent(clips[ui.clip].info.name), 'frame=' + ui.frame);
    if (ui.mesh !== 'solid') parts.push('mesh=' + ui.mesh);
    if (!ui.spheres) parts.push('spheres=0');
    if (!ui.contacts) parts.push('contacts=0');
    if (!ui.loosest) parts.push('loosest=0');
    if (ui.excluded) parts.push('excluded=1');
    if (data.colliders && !ui.colliders) parts.push('colliders=0');
    if (ui.overlaps) parts.push('overlaps=1');
    if (ui.color !== 'part') parts.push('color=' + ui.color);
    if (ui.selected >= 0) parts.push('sphere=' + ui.selected);
    if (ui.view !== 'front') parts.push('view=' + ui.view);
    try {
      history.replaceState(null, '', '#' + parts.join('&'));
    } catch (e) {
      // Some browsers refuse replaceState on file:// pages; the hash is a convenience.
    }
  }
  window.addEventListener('hashchange', applyHash);

  // ---------------------------------------------------------------------------------------------
  // Rendering and playback

  var playClock = 0, lastTick = 0;
  function resize() {
    var w = canvas.clientWidth, h = canvas.clientHeight;
    if (canvas.width !== Math.floor(w * renderer.getPixelRatio()) || canvas.height !== Math.floor(h * renderer.getPixelRatio())) {
      renderer.setSize(w, h, false);
      camera.aspect = w / Math.max(h, 1);
      camera.updateProjectionMatrix();
    }
  }
  function renderNow(now) {
    renderPending = false;
    if (ui.playing) {
      var info = clips[ui.clip].info;
      playClock += Math.max(0, (now - lastTick) / 1000) * ui.speed;
      lastTick = now;
      var f = Math.floor(playClock * info.fps + 1e-6) % info.frames;
      if (f !== ui.frame) { ui.frame = f; updateFrame(); }
      requestRender();
    }
    resize();
    renderer.render(scene, camera);
    setState('rendered', Number(stateEl.getAttribute('data-rendered') || 0) + 1);
  }
  controls.addEventListener('change', requestRender);
  window.addEventListener('resize', function () { requestRender(); updateTimelineHead(); });

  // Screen box (CSS pixels, relative to the viewport) of spheres at the current frame: their
  // centres, or with `whole` their silhouettes (centre +- r along the camera's right and up axes,
  // a close bound at this field of view). For tests and for anyone scripting the page.
  function screenBox(ids, whole) {
    var xyzr = currentXyzr();
    var rect = canvas.getBoundingClientRect();
    var box = { left: Infinity, top: Infinity, right: -Infinity, bottom: -Infinity };
    camera.updateMatrixWorld();
    var right = new THREE.Vector3().setFromMatrixColumn(camera.matrixWorld, 0);
    var up = new THREE.Vector3().setFromMatrixColumn(camera.matrixWorld, 1);
    ids.forEach(function (id) {
      var c2 = new THREE.Vector3(xyzr[4 * id], xyzr[4 * id + 1], xyzr[4 * id + 2]);
      var r2 = whole ? xyzr[4 * id + 3] : 0;
      [[0, 0], [1, 0], [-1, 0], [0, 1], [0, -1]].forEach(function (o) {
        var v = c2.clone().addScaledVector(right, o[0] * r2).addScaledVector(up, o[1] * r2).project(camera);
        var x = rect.left + (v.x + 1) / 2 * rect.width, y = rect.top + (1 - v.y) / 2 * rect.height;
        box.left = Math.min(box.left, x); box.right = Math.max(box.right, x);
        box.top = Math.min(box.top, y); box.bottom = Math.max(box.bottom, y);
      });
    });
    return box;
  }
  window.skinspheresViewer = {
    data: data,
    setClip: function (i) { setClip(i); saveHash(); },
    setFrame: setFrame,
    select: select,
    screenBox: screenBox,
    // The drawn pieces' corners, world space, 9 floats per piece (tests compare them with the spheres).
    pieceCorners: function () {
      if (!pieceMesh || !pieceMesh.visible) return [];
      return Array.from(pieceMesh.geometry.getAttribute('position').array.subarray(0, pieceMesh.geometry.drawRange.count * 3));
    },
    render: function () { resize(); renderer.render(scene, camera); }
  };

  // ---------------------------------------------------------------------------------------------
  // Start

  fillStaticPanels();
  var glbText = $('ss-glb').textContent;
  new THREE.GLTFLoader().parse(bytesOfBase64(glbText).buffer, '', function (gltf) {
    setupCharacter(gltf);
    applyHash();
    setState('errors', window.ssErrors.length);
    setState('ready', 1);
  }, function (err) {
    fail('the character cannot be read: ' + (err && err.message ? err.message : err));
    applyHash();
    setState('ready', 1);
  });
})();
