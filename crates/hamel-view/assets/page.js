// hamel's animated page: plays the motion the page carries in #hamel-data with three.js.
// Every text from a model or a scene reaches the page through JSON and enters it as text
// (textContent, canvas text), never as markup (SECURITY.md).
(function () {
  'use strict';
  const errors = [];
  window.addEventListener('error', (e) => errors.push(String(e.message)));
  const $ = (id) => document.getElementById(id);
  const data = JSON.parse($('hamel-data').textContent);

  // Little-endian float64 arrays, as hamel writes them (base64).
  function f64(b64) {
    const s = atob(b64);
    const view = new DataView(new ArrayBuffer(s.length));
    for (let i = 0; i < s.length; i++) view.setUint8(i, s.charCodeAt(i));
    const out = new Float64Array(s.length / 8);
    for (let i = 0; i < out.length; i++) out[i] = view.getFloat64(8 * i, true);
    return out;
  }

  const drawing = data.drawing;
  const frames = drawing ? drawing.frames : [];
  const nf = frames.length;
  const nc = drawing ? drawing.contacts.length : 0;
  const members = data.members.map((m) => ({
    label: m.label,
    t: f64(m.t),
    poses: f64(m.poses),
    tracks: f64(m.tracks),
    series: m.series.map((s) => ({ name: s.name, values: f64(s.values) })),
    arrows: m.arrows.map((a) => ({ name: a.name, contact: a.contact, vectors: f64(a.vectors) })),
  }));
  const colours = ['#4e79a7', '#f28e2b', '#59a14f', '#e15759', '#b07aa1', '#edc948', '#76b7b2', '#ff9da7', '#9c755f'];

  // ---- time and poses -------------------------------------------------------------------
  // The output interval holding t: index i with t_i <= t < t_{i+1}, and the weight of t_{i+1}.
  function locate(times, t) {
    const n = times.length;
    if (n === 0 || !(t > times[0])) return [0, 0];
    if (t >= times[n - 1]) return [n - 1, 0];
    let lo = 0;
    let hi = n - 1;
    while (hi - lo > 1) {
      const mid = (lo + hi) >> 1;
      if (times[mid] <= t) lo = mid;
      else hi = mid;
    }
    return [lo, (t - times[lo]) / (times[lo + 1] - times[lo])];
  }

  // Spherical interpolation of unit quaternions (w, x, y, z), the shorter way round; the
  // angle from atan2 of the chord and its complement, accurate at small angles.
  function slerp(a, b, w) {
    const dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
    const s = dot < 0 ? -1 : 1;
    const bb = b.map((c) => s * c);
    const chord = Math.hypot(a[0] - bb[0], a[1] - bb[1], a[2] - bb[2], a[3] - bb[3]);
    const sum = Math.hypot(a[0] + bb[0], a[1] + bb[1], a[2] + bb[2], a[3] + bb[3]);
    const th = 2 * Math.atan2(chord, sum);
    let k0 = 1 - w;
    let k1 = w;
    if (th > 1e-9) {
      const st = Math.sin(th);
      k0 = Math.sin((1 - w) * th) / st;
      k1 = Math.sin(w * th) / st;
    }
    const q = a.map((c, i) => k0 * c + k1 * bb[i]);
    const n = Math.hypot(q[0], q[1], q[2], q[3]);
    return q.map((c) => c / n);
  }

  function storedPose(m, i, k) {
    const p = m.poses;
    const o = (i * nf + k) * 7;
    return {
      position: [p[o], p[o + 1], p[o + 2]],
      rotation: [p[o + 3], p[o + 4], p[o + 5], p[o + 6]],
    };
  }

  // Every drawn frame's pose at time t: the stored one at an output time, interpolated
  // between two (positions linearly, rotations by slerp).
  function poseAt(t, member) {
    const m = members[member || 0];
    const out = {};
    if (!m || m.t.length === 0) return out;
    const [i, w] = locate(m.t, t);
    for (let k = 0; k < nf; k++) {
      const a = storedPose(m, i, k);
      if (w === 0) {
        out[frames[k]] = a;
        continue;
      }
      const b = storedPose(m, i + 1, k);
      out[frames[k]] = {
        position: a.position.map((x, j) => x + w * (b.position[j] - x)),
        rotation: slerp(a.rotation, b.rotation, w),
      };
    }
    return out;
  }

  // A vector series (3 per time) at t, interpolated linearly.
  function vectorAt(values, times, t, k, stride) {
    const [i, w] = locate(times, t);
    const o = (i * stride + k) * 3;
    if (w === 0) return [values[o], values[o + 1], values[o + 2]];
    const o2 = o + stride * 3;
    return [0, 1, 2].map((j) => values[o + j] + w * (values[o2 + j] - values[o + j]));
  }

  const t0 = Math.min(...members.map((m) => (m.t.length ? m.t[0] : Infinity)));
  const t1 = Math.max(...members.map((m) => (m.t.length ? m.t[m.t.length - 1] : -Infinity)));
  let now = Number.isFinite(t0) ? t0 : 0;

  // ---- header -----------------------------------------------------------------------------
  $('title').textContent = data.title;
  $('subtitle').textContent = data.subtitle;

  // ---- the 3D view ------------------------------------------------------------------------
  let three = null;
  if (drawing) {
    try {
      three = build3d();
    } catch (e) {
      errors.push(String(e && e.message ? e.message : e));
      showNote('The 3D view could not start (' + String(e && e.message ? e.message : e) + '); the plots still work.');
    }
  } else {
    showNote(data.note || 'Nothing to draw.');
    for (const id of ['tracks', 'axes', 'forces', 'follow']) $(id).closest('label').hidden = true;
  }

  function showNote(text) {
    const note = $('note');
    note.textContent = text;
    note.hidden = false;
  }

  function build3d() {
    const T = window.THREE;
    const view = $('view');
    const renderer = new T.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    renderer.setPixelRatio(window.devicePixelRatio || 1);
    view.appendChild(renderer.domElement);
    const scene = new T.Scene();
    scene.background = new T.Color(0xf4f4f2);
    const up = new T.Vector3().fromArray(drawing.up);
    const upIndex = drawing.up.findIndex((c) => c !== 0);
    const h1 = new T.Vector3().setComponent((upIndex + 1) % 3, 1);
    const h2 = new T.Vector3().crossVectors(up, h1);
    const scale = drawing.scale;

    const hemi = new T.HemisphereLight(0xffffff, 0x8a8a80, 2.2);
    hemi.position.copy(up);
    scene.add(hemi);
    const sun = new T.DirectionalLight(0xffffff, 1.6);
    sun.position.copy(up).multiplyScalar(10).addScaledVector(h1, -4).addScaledVector(h2, -3);
    scene.add(sun);

    const quaternion = (q) => new T.Quaternion(q[1], q[2], q[3], q[0]);
    const overlay = members.length > 1;
    function material(rgb, opacity) {
      return new T.MeshStandardMaterial({
        color: new T.Color(rgb[0] / 255, rgb[1] / 255, rgb[2] / 255),
        roughness: 0.65,
        metalness: 0.05,
        transparent: opacity < 1,
        opacity,
      });
    }
    function solid(d) {
      const f = d.form;
      const mat = material(d.colour, d.form.kind === 'ellipsoid' ? 0.85 : 1);
      switch (f.kind) {
        case 'box':
          return new T.Mesh(new T.BoxGeometry(2 * f.half[0], 2 * f.half[1], 2 * f.half[2]), mat);
        case 'ellipsoid': {
          const m = new T.Mesh(new T.SphereGeometry(1, 32, 16), mat);
          m.scale.set(f.half[0], f.half[1], f.half[2]);
          return m;
        }
        case 'cylinder':
          return new T.Mesh(new T.CylinderGeometry(f.radius, f.radius, f.length, 32), mat);
        case 'sphere':
          return new T.Mesh(new T.SphereGeometry(f.radius, 32, 16), mat);
        case 'wheel': {
          const g = new T.Group();
          g.add(new T.Mesh(new T.CylinderGeometry(f.radius, f.radius, f.width, 48), mat));
          const spoke = new T.Mesh(
            new T.BoxGeometry(0.92 * f.radius, 1.3 * f.width, 0.12 * f.radius),
            material([235, 235, 225], 1),
          );
          spoke.position.x = 0.46 * f.radius;
          g.add(spoke);
          return g;
        }
        default:
          throw new Error('unknown solid ' + f.kind);
      }
    }

    // One group per member, one per drawn frame inside it.
    const groups = members.map((m, j) => {
      const group = new T.Group();
      const frameGroups = frames.map(() => {
        const g = new T.Group();
        const axes = new T.AxesHelper(0.6 * scale);
        axes.visible = false;
        g.add(axes);
        g.userData.axes = axes;
        group.add(g);
        return g;
      });
      for (const d of drawing.drawn) {
        const obj = solid(d);
        obj.position.fromArray(d.centre);
        obj.quaternion.copy(quaternion(d.rotation));
        frameGroups[d.frame].add(obj);
      }
      const tracks = drawing.contacts.map((c, k) => {
        const n = m.t.length;
        const pts = new Float32Array(3 * n);
        for (let i = 0; i < n; i++) {
          for (let x = 0; x < 3; x++) pts[3 * i + x] = m.tracks[(i * nc + k) * 3 + x];
        }
        const geom = new T.BufferGeometry();
        geom.setAttribute('position', new T.BufferAttribute(pts, 3));
        const line = new T.Line(geom, new T.LineBasicMaterial({ color: overlay ? colours[j % colours.length] : '#c0392b' }));
        line.frustumCulled = false;
        group.add(line);
        return line;
      });
      const arrows = m.arrows.map(() => {
        const a = new T.ArrowHelper(up.clone(), new T.Vector3(), 1, 0xd62728);
        group.add(a);
        return a;
      });
      scene.add(group);
      return { group, frameGroups, tracks, arrows };
    });

    // The largest force drawn 1.5 scales long.
    let largest = 0;
    for (const m of members) {
      for (const a of m.arrows) {
        for (let i = 0; i + 2 < a.vectors.length; i += 3) {
          const n = Math.hypot(a.vectors[i], a.vectors[i + 1], a.vectors[i + 2]);
          if (Number.isFinite(n)) largest = Math.max(largest, n);
        }
      }
    }
    const forceScale = largest > 0 ? (1.5 * scale) / largest : 0;

    // The extent of the motion in the ground plane (member 0's frames and tracks, all times).
    function extent(m) {
      const box = new T.Box3();
      const v = new T.Vector3();
      for (let i = 0; i + 2 < m.poses.length; i += 7) box.expandByPoint(v.set(m.poses[i], m.poses[i + 1], m.poses[i + 2]));
      for (let i = 0; i + 2 < m.tracks.length; i += 3) box.expandByPoint(v.set(m.tracks[i], m.tracks[i + 1], m.tracks[i + 2]));
      if (box.isEmpty()) box.expandByPoint(v.set(0, 0, 0));
      return box;
    }
    const boxes = members.map(extent);

    // Grid cells of 1, 2 or 5 times a power of ten, at least twice the scale.
    function cell() {
      const target = 2 * scale;
      const power = Math.pow(10, Math.floor(Math.log10(target)));
      return [1, 2, 5, 10].map((k) => k * power).find((c) => c >= target);
    }

    // A square grid of cells × cells in three's xz plane, each line cut at every crossing:
    // short segments, so that a line passing behind the camera is not lost whole where a
    // renderer (SwiftShader) clips long lines poorly.
    function makeGrid(cells, step) {
      const half = (cells * step) / 2;
      const pts = [];
      for (let i = 0; i <= cells; i++) {
        const a = -half + i * step;
        for (let j = 0; j < cells; j++) {
          const b = -half + j * step;
          pts.push(a, 0, b, a, 0, b + step, b, 0, a, b + step, 0, a);
        }
      }
      const geom = new T.BufferGeometry();
      geom.setAttribute('position', new T.Float32BufferAttribute(pts, 3));
      return new T.LineSegments(geom, new T.LineBasicMaterial({ color: 0xc8c8c0 }));
    }

    // Members side by side stand six scales apart across the first horizontal axis (their
    // motions may cross: "overlaid" puts them on one spot).
    let grid = null;
    function layout(kind) {
      const gap = 6 * scale;
      groups.forEach((g, j) => g.group.position.copy(h2).multiplyScalar(kind === 'side' ? -j * gap : 0));
      const all = new T.Box3();
      groups.forEach((g, j) => all.union(boxes[j].clone().translate(g.group.position)));
      if (grid) scene.remove(grid);
      const centre = all.getCenter(new T.Vector3());
      const size = all.getSize(new T.Vector3());
      const reach = Math.max(Math.abs(size.dot(h1)), Math.abs(size.dot(h2)));
      const step = cell();
      const cells = Math.min(200, Math.ceil((reach + 2 * Math.max(20 * scale, 0.5 * reach)) / step));
      grid = makeGrid(cells, step);
      grid.quaternion.setFromUnitVectors(new T.Vector3(0, 1, 0), up);
      grid.position.copy(centre).addScaledVector(up, -centre.dot(up));
      scene.add(grid);
    }
    layout('side');

    // Member j's frames at time t.
    function placeFrames(j, t) {
      const poses = poseAt(t, j);
      frames.forEach((f, k) => {
        const p = poses[f];
        if (!p) return;
        groups[j].frameGroups[k].position.fromArray(p.position);
        groups[j].frameGroups[k].quaternion.copy(quaternion(p.rotation));
      });
    }

    // The camera looks at every member's solids at the start, from far enough to see them all.
    const camera = new T.PerspectiveCamera(40, 1, 0.01 * scale, 1000 * scale);
    camera.up.copy(up);
    // The solids' bounds with every member placed at the start (tracks and arrows aside).
    const bounds = new T.Box3();
    members.forEach((m, j) => {
      placeFrames(j, now);
      groups[j].group.updateMatrixWorld(true);
      for (const f of groups[j].frameGroups) {
        for (const child of f.children) {
          if (child !== f.userData.axes) bounds.expandByObject(child);
        }
      }
    });
    if (bounds.isEmpty()) bounds.expandByPoint(new T.Vector3());
    const focus = bounds.getCenter(new T.Vector3());
    const radius = Math.max(0.5 * bounds.getSize(new T.Vector3()).length(), scale);
    const view0 = new T.Vector3().addScaledVector(h1, -0.55).addScaledVector(h2, -0.75).addScaledVector(up, 0.4).normalize();
    camera.position.copy(focus).addScaledVector(view0, 3.0 * radius);
    const controls = new T.OrbitControls(camera, renderer.domElement);
    controls.target.copy(focus);
    controls.update();

    function resize() {
      const w = view.clientWidth || 640;
      const h = view.clientHeight || 480;
      renderer.setSize(w, h, false);
      camera.aspect = w / h;
      camera.updateProjectionMatrix();
      // A new size clears the drawing buffer: draw again.
      renderer.render(scene, camera);
    }
    window.addEventListener('resize', resize);
    resize();

    let followed = null;
    function place(t) {
      members.forEach((m, j) => {
        const g = groups[j];
        placeFrames(j, t);
        const [i] = locate(m.t, t);
        g.tracks.forEach((line) => line.geometry.setDrawRange(0, i + 1));
        m.arrows.forEach((a, x) => {
          const helper = g.arrows[x];
          const f = vectorAt(a.vectors, m.t, t, 0, 1);
          const n = Math.hypot(f[0], f[1], f[2]);
          helper.visible = $('forces').checked && Number.isFinite(n) && n > 0;
          if (!helper.visible) return;
          helper.position.fromArray(vectorAt(m.tracks, m.t, t, a.contact, nc));
          helper.setDirection(new T.Vector3().fromArray(f).multiplyScalar(1 / n));
          helper.setLength(n * forceScale, 0.2 * scale, 0.1 * scale);
        });
      });
      if (followed !== null) {
        const p = poseAt(t, 0)[frames[followed]];
        const target = new T.Vector3().fromArray(p.position).add(groups[0].group.position);
        const delta = target.clone().sub(controls.target);
        camera.position.add(delta);
        controls.target.copy(target);
      }
    }

    // Controls that concern the 3D view only.
    const follow = $('follow');
    for (const [body, k] of Object.entries(drawing.bodies)) {
      const o = document.createElement('option');
      o.value = String(k);
      o.textContent = body;
      follow.appendChild(o);
    }
    // A motion that travels far is followed from the start (by the first body).
    const travel = boxes[0].getSize(new T.Vector3()).length();
    const first = Object.values(drawing.bodies)[0];
    if (travel > 8 * scale && first !== undefined) {
      follow.value = String(first);
      followed = first;
    }
    follow.addEventListener('change', () => {
      followed = follow.value === '' ? null : Number(follow.value);
      update();
    });
    $('axes').addEventListener('change', (e) => {
      for (const g of groups) for (const f of g.frameGroups) f.userData.axes.visible = e.target.checked;
      update();
    });
    $('tracks').addEventListener('change', (e) => {
      for (const g of groups) for (const l of g.tracks) l.visible = e.target.checked;
      update();
    });
    if (members.length > 1) {
      $('layout-label').hidden = false;
      $('layout').addEventListener('change', (e) => {
        layout(e.target.value);
        update();
      });
    }
    controls.addEventListener('change', () => renderer.render(scene, camera));
    return { place, render: () => renderer.render(scene, camera), canvas: renderer.domElement };
  }

  // ---- plots --------------------------------------------------------------------------------
  if (members.length > 1) {
    const legend = document.createElement('ul');
    legend.id = 'legend';
    members.forEach((m, j) => {
      const item = document.createElement('li');
      const swatch = document.createElement('span');
      swatch.className = 'swatch';
      swatch.style.background = colours[j % colours.length];
      item.appendChild(swatch);
      item.appendChild(document.createTextNode(m.label));
      legend.appendChild(item);
    });
    $('plots').appendChild(legend);
  }
  const names = [];
  for (const m of members) for (const s of m.series) if (!names.includes(s.name)) names.push(s.name);
  const plots = names.map((name) => {
    const fig = document.createElement('figure');
    const cap = document.createElement('figcaption');
    cap.textContent = name;
    const canvas = document.createElement('canvas');
    const ratio = window.devicePixelRatio || 1;
    canvas.width = 320 * ratio;
    canvas.height = 110 * ratio;
    fig.appendChild(cap);
    fig.appendChild(canvas);
    $('plots').appendChild(fig);
    const base = document.createElement('canvas');
    base.width = canvas.width;
    base.height = canvas.height;
    const ctx = base.getContext('2d');
    ctx.scale(ratio, ratio);
    let lo = Infinity;
    let hi = -Infinity;
    for (const m of members) {
      const s = m.series.find((x) => x.name === name);
      if (s) for (const v of s.values) if (Number.isFinite(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
    }
    if (!Number.isFinite(lo)) { lo = -1; hi = 1; }
    // A quantity constant to round-off (a conserved energy) is drawn flat, not its noise.
    const floor = Math.max(1e-6 * Math.max(Math.abs(lo), Math.abs(hi)), 1e-12);
    if (hi - lo < floor) { const mid = 0.5 * (hi + lo); lo = mid - floor; hi = mid + floor; }
    const x = (t) => 54 + ((t - t0) / (t1 - t0 || 1)) * 258;
    const y = (v) => 100 - ((v - lo) / (hi - lo)) * 92;
    ctx.fillStyle = '#fff';
    ctx.fillRect(0, 0, 320, 110);
    ctx.strokeStyle = '#bbb';
    ctx.strokeRect(54, 8, 258, 92);
    ctx.fillStyle = '#555';
    ctx.font = '10px system-ui, sans-serif';
    ctx.fillText(hi.toPrecision(4), 2, 14);
    ctx.fillText(lo.toPrecision(4), 2, 100);
    members.forEach((m, j) => {
      const s = m.series.find((z) => z.name === name);
      if (!s) return;
      ctx.strokeStyle = colours[j % colours.length];
      ctx.lineWidth = 1.4;
      ctx.beginPath();
      let pen = false;
      s.values.forEach((v, i) => {
        if (!Number.isFinite(v)) { pen = false; return; }
        if (pen) ctx.lineTo(x(m.t[i]), y(v));
        else ctx.moveTo(x(m.t[i]), y(v));
        pen = true;
      });
      ctx.stroke();
    });
    return { canvas, base, x, ratio };
  });

  function drawCursors(t) {
    for (const p of plots) {
      const ctx = p.canvas.getContext('2d');
      ctx.setTransform(1, 0, 0, 1, 0, 0);
      ctx.drawImage(p.base, 0, 0);
      ctx.scale(p.ratio, p.ratio);
      ctx.strokeStyle = '#d62728';
      ctx.beginPath();
      ctx.moveTo(p.x(t), 8);
      ctx.lineTo(p.x(t), 100);
      ctx.stroke();
    }
  }

  // ---- playing ------------------------------------------------------------------------------
  const slider = $('slider');
  let playing = false;
  let last = null;
  function update() {
    if (three) {
      three.place(now);
      three.render();
    }
    drawCursors(now);
    $('clock').textContent = 't = ' + now.toFixed(3);
    slider.value = String(Math.round(((now - t0) / (t1 - t0 || 1)) * 10000));
  }
  function setTime(t) {
    now = Math.min(Math.max(t, t0), t1);
    update();
  }
  function setPlaying(p) {
    playing = p;
    last = null;
    $('play').textContent = p ? '\u275a\u275a' : '\u25b6';
  }
  $('play').addEventListener('click', () => {
    if (!playing && now >= t1) now = t0;
    setPlaying(!playing);
  });
  document.addEventListener('keydown', (e) => {
    if (e.code === 'Space' && e.target === document.body) {
      e.preventDefault();
      $('play').click();
    }
  });
  slider.addEventListener('input', () => {
    setPlaying(false);
    setTime(t0 + (Number(slider.value) / 10000) * (t1 - t0));
  });
  $('forces').addEventListener('change', update);
  function tick(stamp) {
    if (playing) {
      if (last !== null) {
        let t = now + ((stamp - last) / 1000) * Number($('speed').value);
        if (t > t1) {
          if ($('loop').checked) t = t0;
          else { t = t1; setPlaying(false); }
        }
        now = t;
        update();
      }
      last = stamp;
    }
    requestAnimationFrame(tick);
  }

  // #t=VALUE starts paused at that time; #probe writes poseAt at every output time and a
  // quarter of the way to the next into #hamel-probe (for tests).
  const hash = new Map(location.hash.slice(1).split('&').map((kv) => kv.split('=')));
  if (hash.has('t')) setTime(Number(hash.get('t')));
  else setTime(now);
  if (!hash.has('t') && !hash.has('probe')) setPlaying(true);
  requestAnimationFrame(tick);

  window.hamel = {
    poseAt,
    frames: frames.slice(),
    bodies: Object.fromEntries(Object.entries(drawing ? drawing.bodies : {}).map(([b, k]) => [b, frames[k]])),
    members: members.map((m) => m.label),
    times: (member) => Array.from(members[member || 0].t),
    setTime,
    errors,
  };

  if (hash.has('probe')) {
    const m = members[0];
    const times = [];
    for (let i = 0; i < m.t.length; i++) {
      times.push(m.t[i]);
      if (i + 1 < m.t.length) times.push(m.t[i] + 0.25 * (m.t[i + 1] - m.t[i]));
    }
    const pre = document.createElement('pre');
    pre.id = 'hamel-probe';
    pre.textContent = JSON.stringify({
      errors,
      webgl: three !== null,
      frames,
      bodies: window.hamel.bodies,
      plots: names,
      times,
      poses: times.map((t) => poseAt(t, 0)),
      members: members.map((mm, j) => ({
        label: mm.label,
        end: mm.t.length ? mm.t[mm.t.length - 1] : null,
        last: mm.t.length ? poseAt(mm.t[mm.t.length - 1], j) : {},
      })),
    });
    document.body.appendChild(pre);
  }
})();
