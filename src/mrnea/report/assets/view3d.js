// mrnea report: the 3D view of the programmed (ghost) and the real motion.
// Reads the JSON spec and the binary payload that report/view3d.py writes into the page (the
// HTML around it: report/view3d_html.py), builds the scene
// with three.js (the vendored subset, global MRNEA_THREE) and plays it back on the cycle clock.
// Everything comes from the page itself: no request, works from file://.
// Public: window.mrneaView3d = {ready, setTime(t), time(), play(), pause(), renders()}; every change
// of time dispatches a bubbling 'mrnea:time' CustomEvent with detail {t, playing} on the view.
(function () {
  "use strict";
  const THREE = globalThis.MRNEA_THREE;
  const C = { real: 0x5b7fa6, sat: 0xd62728, ghost: 0x9aa3ad, trace: 0x1f77b4, traceCmd: 0x595959,
              target: 0xc51b8a };

  function bytesFromBase64(s) {
    const bin = atob(s);
    const out = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
    return out;
  }

  async function payload(spec) {
    const raw = bytesFromBase64(spec.payload);
    if (!spec.gzip) return raw.buffer;
    const stream = new Blob([raw]).stream().pipeThrough(new DecompressionStream("gzip"));
    return await new Response(stream).arrayBuffer();
  }

  // Typed view of one section [offset, count] of the payload.
  function section(buf, sec, Type) { return new Type(buf, sec[0], sec[1]); }

  // Link poses of one robot, (F, n, 7) floats: origin, quaternion (x, y, z, w). Stored as int16
  // frame-to-frame differences modulo 2^16, low-byte plane then high-byte plane, each (n, 7, F)
  // (view3d.py: pack); the running sum, wrapped to int16, gives the quantised value exactly:
  // origins in the scene box, quaternions times 32767 (view3d.py: quantise).
  function poses(buf, sec, spec, F, n) {
    const b = section(buf, sec, Uint8Array), m = F * n * 7, out = new Float32Array(m);
    const lo = spec.box[0], hi = spec.box[1];
    for (let i = 0; i < n; i++) {
      for (let a = 0; a < 7; a++) {
        const base = (i * 7 + a) * F;
        let v = 0;
        for (let k = 0; k < F; k++) {
          v = ((v + (b[base + k] | (b[m + base + k] << 8))) << 16) >> 16;
          out[(k * n + i) * 7 + a] = a < 3 ? lo[a] + (v + 32767) / 65534 * (hi[a] - lo[a]) : v / 32767;
        }
      }
    }
    return out;
  }

  function geometryOf(shape, meshes, buf) {
    const s = shape.s;
    switch (shape.k) {
      case "box": return new THREE.BoxGeometry(s[0], s[1], s[2]);
      case "sphere": return new THREE.SphereGeometry(s[0], 24, 16);
      // three's cylinder and capsule run along y; URDF's along z: turned by the caller
      case "cylinder": return new THREE.CylinderGeometry(s[0], s[0], s[1], 32);
      case "capsule": return new THREE.CapsuleGeometry(s[0], s[1], 6, 20);
      case "mesh": {
        const m = meshes[shape.m];
        const g = new THREE.BufferGeometry();
        g.setAttribute("position", new THREE.BufferAttribute(section(buf, m.v, Float32Array), 3));
        g.setIndex(new THREE.BufferAttribute(section(buf, m.f, m.f32 ? Uint32Array : Uint16Array), 1));
        g.scale(s[0], s[1], s[2]);
        g.computeVertexNormals();
        return g;
      }
    }
    throw new Error("mrnea view3d: unknown shape kind " + shape.k);
  }

  // One robot (base + n links) as groups; returns {groups, parts} where parts[j] lists the
  // materials to redden when joint j saturates.
  function buildRobot(spec, meshes, buf, ghost) {
    const groups = [], parts = spec.joints.map(() => []);
    spec.shapes.forEach((list, li) => {   // li = 0: the base, li = i + 1: link i
      const g = new THREE.Group();
      for (const sh of list) {
        const geo = geometryOf(sh, meshes, buf);
        if (sh.k === "cylinder" || sh.k === "capsule") geo.rotateX(Math.PI / 2);
        const color = sh.c !== undefined ? sh.c : C.real;
        // a decimated mesh may be open or turned inside out in places: draw both sides
        const side = sh.k === "mesh" ? THREE.DoubleSide : THREE.FrontSide;
        const mat = ghost
          ? new THREE.MeshBasicMaterial({ color: C.ghost, transparent: true, opacity: 0.38,
                                          depthWrite: false, polygonOffset: true, side,
                                          polygonOffsetFactor: 2, polygonOffsetUnits: 2 })
          : new THREE.MeshStandardMaterial({ color, roughness: 0.55, metalness: 0.15, side });
        const mesh = new THREE.Mesh(geo, mat);
        mesh.position.fromArray(sh.p, 0);
        mesh.quaternion.fromArray(sh.p, 3);
        mesh.castShadow = !ghost;
        g.add(mesh);
        if (ghost && sh.k !== "mesh") {  // outline: the ghost reads as a shape, not a haze
          // (a mesh's many small creases would draw a tangle of lines instead)
          const edges = new THREE.LineSegments(new THREE.EdgesGeometry(geo, 30),
            new THREE.LineBasicMaterial({ color: 0x4a4f57, transparent: true, opacity: 0.75 }));
          mesh.add(edges);
        }
        if (!ghost && sh.j >= 0) parts[sh.j].push({ mat, color });
      }
      groups.push(g);
    });
    return { groups, parts };
  }

  function niceStep(x) {  // 1, 2, 5 x 10^k at or above x
    const p = Math.pow(10, Math.floor(Math.log10(x)));
    for (const m of [1, 2, 5, 10]) if (m * p >= x) return m * p;
    return 10 * p;
  }

  function decimals(dt) { return Math.max(3, Math.ceil(-Math.log10(dt) - 1e-9)); }

  async function init(root) {
    const spec = JSON.parse(root.querySelector("script.mv3d-data").textContent);
    const buf = await payload(spec);
    const F = spec.frames, n = spec.joints.length;
    const times = section(buf, spec.bin.time, Float64Array);
    const real = poses(buf, spec.bin.real, spec, F, n);
    const cmd = spec.bin.cmd ? poses(buf, spec.bin.cmd, spec, F, n) : null;
    const sat = section(buf, spec.bin.sat, Uint8Array);

    const canvas = root.querySelector("canvas");
    // three.js needs WebGL 2; ask a scratch canvas first (three would log errors of its own)
    const probe = document.createElement("canvas").getContext("webgl2");
    if (!probe) {
      root.querySelector(".mv3d-stage").classList.add("mv3d-nogl");
      console.warn("mrnea view3d: this browser gives the page no WebGL 2; 3D view off");
      return null;
    }
    const lose = probe.getExtension("WEBGL_lose_context");
    if (lose) lose.loseContext();
    const renderer = new THREE.WebGLRenderer({ canvas, antialias: true });
    renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
    renderer.outputColorSpace = THREE.SRGBColorSpace;
    renderer.shadowMap.enabled = true;
    renderer.shadowMap.type = THREE.PCFSoftShadowMap;

    const scene = new THREE.Scene();
    scene.background = new THREE.Color(0xfafbfc);
    const lo = new THREE.Vector3().fromArray(spec.bounds[0]);
    const hi = new THREE.Vector3().fromArray(spec.bounds[1]);
    const centre = lo.clone().add(hi).multiplyScalar(0.5);
    const radius = Math.max(hi.clone().sub(lo).length() / 2, 1e-3);
    const floorZ = Math.min(0, lo.z);

    // lights: sky/ground fill plus one sun that casts the real robot's shadow on the floor
    scene.add(new THREE.HemisphereLight(0xffffff, 0x8d8d8d, 2.0));
    const sun = new THREE.DirectionalLight(0xffffff, 2.2);
    sun.position.copy(centre).add(new THREE.Vector3(0.5, -0.8, 1.6).multiplyScalar(3 * radius));
    sun.target.position.copy(centre);
    sun.castShadow = true;
    sun.shadow.mapSize.set(2048, 2048);
    Object.assign(sun.shadow.camera, { left: -2 * radius, right: 2 * radius, top: 2 * radius,
                                       bottom: -2 * radius, near: 0.1 * radius, far: 8 * radius });
    scene.add(sun, sun.target);

    // floor: a grid of round spacing in the base's x-y plane at the lowest point reached
    const cell = niceStep(radius / 5);
    const half = Math.ceil((0.15 * radius + Math.max(hi.x - lo.x, hi.y - lo.y) / 2) / cell) * cell;
    const grid = new THREE.GridHelper(2 * half, Math.round(2 * half / cell), 0xbfc4ca, 0xdfe2e6);
    grid.rotateX(Math.PI / 2);
    grid.position.set(Math.round(centre.x / cell) * cell, Math.round(centre.y / cell) * cell, floorZ);
    scene.add(grid);
    const floor = new THREE.Mesh(new THREE.PlaneGeometry(2 * half, 2 * half),
                                 new THREE.ShadowMaterial({ opacity: 0.18 }));
    floor.position.copy(grid.position).setZ(floorZ - 1e-4 * radius);
    floor.receiveShadow = true;
    scene.add(floor);
    const axes = new THREE.AxesHelper(0.5 * cell * 2);  // base frame: x red, y green, z blue
    scene.add(axes);
    root.querySelector(".mv3d-grid").textContent = "grid " + cell + " m";

    const meshes = spec.meshes || [];
    const realRobot = buildRobot(spec, meshes, buf, false);
    realRobot.groups.forEach((g) => scene.add(g));
    const ghost = cmd ? buildRobot(spec, meshes, buf, true) : null;
    if (ghost) ghost.groups.forEach((g) => { g.renderOrder = 1; scene.add(g); });

    // end-effector traces: each tip point (a tree: every branch's; [link, x, y, z], the point in
    // that link's frame) at every frame
    const tips = spec.tips || [[n - 1, ...spec.tip]];
    function tracePoints(P, link, tip) {
      const pts = new Float32Array(3 * F), v = new THREE.Vector3(), q = new THREE.Quaternion();
      for (let k = 0; k < F; k++) {
        const o = (k * n + link) * 7;
        q.set(P[o + 3], P[o + 4], P[o + 5], P[o + 6]);
        v.copy(tip).applyQuaternion(q).add(new THREE.Vector3(P[o], P[o + 1], P[o + 2]));
        v.toArray(pts, 3 * k);
      }
      return pts;
    }
    function trace(P, color, dashed, [link, ...xyz]) {
      const geo = new THREE.BufferGeometry();
      const tip = new THREE.Vector3().fromArray(xyz);
      geo.setAttribute("position", new THREE.BufferAttribute(tracePoints(P, link, tip), 3));
      const full = new THREE.Line(geo, new THREE.LineBasicMaterial({ color, transparent: true,
                                                                       opacity: 0.25 }));
      const done = new THREE.Line(geo.clone(), dashed
        ? new THREE.LineDashedMaterial({ color, dashSize: cell / 4, gapSize: cell / 6 })
        : new THREE.LineBasicMaterial({ color }));
      if (dashed) done.computeLineDistances();
      scene.add(full, done);
      return done.geometry;
    }
    const traces = tips.map((tp) => trace(real, C.trace, false, tp))
      .concat(cmd ? tips.map((tp) => trace(cmd, C.traceCmd, true, tp)) : []);

    // the target poses of a Cartesian program's moves: a dot at the tool point and a stick
    // along the tool's z axis (its approach direction)
    (spec.targets || []).forEach((a) => {
      const g = new THREE.Group();
      g.position.set(a[0], a[1], a[2]);
      g.quaternion.set(a[3], a[4], a[5], a[6]);
      const mat = new THREE.MeshBasicMaterial({ color: C.target });
      g.add(new THREE.Mesh(new THREE.SphereGeometry(cell / 14, 16, 8), mat));
      const stick = new THREE.BufferGeometry().setFromPoints(
        [new THREE.Vector3(0, 0, 0), new THREE.Vector3(0, 0, cell / 2)]);
      g.add(new THREE.Line(stick, new THREE.LineBasicMaterial({ color: C.target })));
      scene.add(g);
    });

    // camera: from the front right and above, at the distance where the box the motion sweeps
    // (every shape over every frame) just fits the canvas; refitted on resize until the user moves it
    const camera = new THREE.PerspectiveCamera(35, 1, 0.01 * radius, 100 * radius);
    camera.up.set(0, 0, 1);
    const controls = new THREE.OrbitControls(camera, canvas);
    let moved = false;
    controls.addEventListener("start", () => { moved = true; });
    function fit() {
      const back = new THREE.Vector3().fromArray(spec.view || [0.55, -1.5, 0.75]).normalize();
      const right = new THREE.Vector3().crossVectors(camera.up, back).normalize();
      const up = new THREE.Vector3().crossVectors(back, right);
      const tv = Math.tan(THREE.MathUtils.degToRad(camera.fov / 2)), th = tv * camera.aspect;
      let d = 0;
      // the support points' extent across the view picks the target, then the distance
      const pts = spec.support.map((a) => new THREE.Vector3().fromArray(a));
      const ext = (v) => [Math.min(...pts.map((p) => p.dot(v))), Math.max(...pts.map((p) => p.dot(v)))];
      const [x0, x1] = ext(right), [y0, y1] = ext(up);
      const aim = centre.clone().addScaledVector(right, (x0 + x1) / 2 - centre.dot(right))
        .addScaledVector(up, (y0 + y1) / 2 - centre.dot(up));
      for (const a of pts) {
        const p = a.clone().sub(aim);
        d = Math.max(d, p.dot(back) + Math.abs(p.dot(right)) / th, p.dot(back) + Math.abs(p.dot(up)) / tv);
      }
      camera.position.copy(aim).addScaledVector(back, 1.03 * d);
      controls.target.copy(aim);
      controls.update();
    }

    // --- time ---------------------------------------------------------------------------------
    const t0 = spec.clock.t0, t1 = spec.clock.t1, dt = spec.clock.dt;
    const slider = root.querySelector("input[type=range]");
    const out = root.querySelector("output");
    const playBtn = root.querySelector(".mv3d-play");
    const speedSel = root.querySelector("select");
    const link = root.querySelector(".mv3d-link");
    const satNote = root.querySelector(".mv3d-sat");
    const nd = decimals(dt);
    let t = t0, playing = false, renders = 0, pending = false, last = null;

    function frameAt(time) {  // k with times[k] <= time < times[k + 1] (clamped), and the fraction
      let a = 0, b = F - 1;
      if (time <= times[0]) return [0, 0];
      if (time >= times[F - 1]) return [F - 1, 0];
      while (b - a > 1) { const m = (a + b) >> 1; if (times[m] <= time) a = m; else b = m; }
      return [a, (time - times[a]) / (times[b] - times[a])];
    }
    const qa = new THREE.Quaternion(), qb = new THREE.Quaternion();
    function pose(groups, P, k, f) {
      const k2 = Math.min(k + 1, F - 1);
      for (let i = 0; i < n; i++) {
        const a = (k * n + i) * 7, b = (k2 * n + i) * 7, g = groups[i + 1];
        g.position.set(P[a] + f * (P[b] - P[a]), P[a + 1] + f * (P[b + 1] - P[a + 1]),
                       P[a + 2] + f * (P[b + 2] - P[a + 2]));
        qa.fromArray(P, a + 3); qb.fromArray(P, b + 3);
        g.quaternion.slerpQuaternions(qa, qb, f);
      }
    }
    function show() {
      const [k, f] = frameAt(t);
      pose(realRobot.groups, real, k, f);
      if (ghost) pose(ghost.groups, cmd, k, f);
      for (const tr of traces) tr.setDrawRange(0, k + 1);
      const names = [];
      for (let j = 0; j < n; j++) {
        const on = sat[k * n + j] !== 0;
        if (on) names.push(spec.joints[j]);
        for (const p of realRobot.parts[j]) {
          p.mat.color.setHex(on ? C.sat : p.color);
          p.mat.emissive.setHex(on ? 0x4a0000 : 0x000000);
        }
      }
      satNote.textContent = names.length ? "saturated: " + names.join(", ") : "";
      slider.value = t;
      out.textContent = t.toFixed(nd) + " s";
      link.href = "#t=" + t.toFixed(nd);
      render();
      root.dispatchEvent(new CustomEvent("mrnea:time", { bubbles: true, detail: { t, playing } }));
    }
    function render() {
      if (pending) return;
      pending = true;
      requestAnimationFrame(() => { pending = false; renderer.render(scene, camera); renders++; });
    }
    function setTime(x) {
      x = Number(x);
      if (!Number.isFinite(x)) return;
      t = Math.min(Math.max(x, t0), t1);
      show();
    }
    function tick(now) {
      if (!playing) return;
      if (last !== null) {
        const next = t + (now - last) / 1000 * Number(speedSel.value);
        if (next >= t1) { setTime(t1); pause(); return; }
        setTime(next);
      }
      last = now;
      requestAnimationFrame(tick);
    }
    function play() {
      if (playing) return;
      if (t >= t1) t = t0;
      playing = true; last = null;
      playBtn.textContent = "❚❚ pause"; playBtn.setAttribute("aria-pressed", "true");
      requestAnimationFrame(tick);
    }
    function pause() {
      playing = false;
      playBtn.textContent = "▶ play"; playBtn.setAttribute("aria-pressed", "false");
      show();
    }

    function resize() {
      const w = canvas.clientWidth, h = canvas.clientHeight;
      if (!w || !h) return;
      renderer.setSize(w, h, false);
      camera.aspect = w / h;
      camera.updateProjectionMatrix();
      if (!moved) fit();
      render();
    }
    new ResizeObserver(resize).observe(canvas);
    controls.addEventListener("change", render);
    slider.addEventListener("input", () => setTime(slider.valueAsNumber));
    playBtn.addEventListener("click", () => (playing ? pause() : play()));
    root.querySelector(".mv3d-home").addEventListener("click", () => { moved = false; fit(); });
    function fromHash(scroll) {
      const m = /^#t=([-+0-9.eE]+)$/.exec(window.location.hash);
      if (!m) return;
      pause();
      setTime(parseFloat(m[1]));
      if (scroll) root.scrollIntoView({ block: "nearest" });
    }
    window.addEventListener("hashchange", () => fromHash(true));
    resize();
    setTime(t0);
    fromHash(false);
    return { setTime, time: () => t, play, pause, renders: () => renders };
  }

  // --- the slider's time over the report's figures ------------------------------------------
  // <figure data-xaxes='[[x0, x1, y0, y1, xmin, xmax], ...]'>: each axes' box in fractions of the
  // PNG (matplotlib's figure coordinates, y up) and its x limits [s]. A vertical line marks the
  // view's time on every axes; a click on an axes moves the view to the time under the pointer.
  function markFigures(api) {
    for (const fig of document.querySelectorAll("figure[data-xaxes]")) {
      const img = fig.querySelector("img");
      const wrap = document.createElement("div");
      wrap.className = "mv3d-figwrap";
      img.replaceWith(wrap);
      wrap.appendChild(img);
      img.title = "click: show this instant in the 3D view";
      const axes = JSON.parse(fig.dataset.xaxes);
      // positions in the image's content box (inside any CSS border): calc(border + f * width)
      const cs = getComputedStyle(img);
      const bl = parseFloat(cs.borderLeftWidth) || 0, bt = parseFloat(cs.borderTopWidth) || 0;
      const bw = bl + (parseFloat(cs.borderRightWidth) || 0);
      const bh = bt + (parseFloat(cs.borderBottomWidth) || 0);
      const at = (f, o, b) => `calc(${o}px + ${f} * (100% - ${b}px))`;
      const lines = axes.map(([, , y0, y1]) => {
        const d = document.createElement("div");
        d.className = "mv3d-tline";
        d.style.top = at(1 - y1, bt, bh);
        d.style.height = at(y1 - y0, 0, bh);
        wrap.appendChild(d);
        return d;
      });
      const update = (t) => axes.forEach(([x0, x1, , , a, b], i) => {
        const inside = t >= a && t <= b;
        lines[i].style.display = inside ? "block" : "none";
        if (inside) lines[i].style.left = at(x0 + (t - a) / (b - a) * (x1 - x0), bl - 1, bw);
      });
      document.addEventListener("mrnea:time", (e) => update(e.detail.t));
      api.time().then((t) => t !== null && t !== undefined && update(t));
      img.addEventListener("click", (e) => {
        const r = img.getBoundingClientRect();
        const fx = (e.clientX - r.left - img.clientLeft) / img.clientWidth;
        const fy = 1 - (e.clientY - r.top - img.clientTop) / img.clientHeight;
        for (const [x0, x1, y0, y1, a, b] of axes) {
          if (fx >= x0 && fx <= x1 && fy >= y0 && fy <= y1) {
            api.setTime(a + (fx - x0) / (x1 - x0) * (b - a));
            break;
          }
        }
      });
    }
  }

  const root = document.querySelector(".mv3d");
  if (!root) return;
  const api = init(root);
  window.mrneaView3d = {
    ready: api,
    setTime: (x) => api.then((a) => a && a.setTime(x)),
    time: () => api.then((a) => a && a.time()),
    play: () => api.then((a) => a && a.play()),
    pause: () => api.then((a) => a && a.pause()),
    renders: () => api.then((a) => (a ? a.renders() : 0)),
  };
  api.catch((err) => console.error("mrnea view3d:", err));
  if (document.readyState === "loading") {
    document.addEventListener("DOMContentLoaded", () => markFigures(window.mrneaView3d));
  } else {
    markFigures(window.mrneaView3d);
  }
})();
