// The Simulator page's live layer, drawn in the browser: the studio sends the robots' state
// (poses, the selected robot's readings, new track points) and this draws it as SVG in the
// view's dynamic layer, in the same elements and classes the server once drew. Every colour,
// width and sensor mount comes from the studio (studio/create/draw.py, create_sim/spec.py).
window.studioSimView = (() => {
  const views = {};

  function esc(text) {
    return String(text).replace(/[&<>"']/g, (c) => `&#${c.charCodeAt(0)};`);
  }
  const f = (v) => v.toFixed(1);
  const pts = (xs, ys) => xs.map((x, i) => `${+x.toFixed(1)},${+ys[i].toFixed(1)}`).join(" ");

  function layerGroup(id) {
    const root = document.getElementById(`c${id}`);
    return root && root.querySelector("svg > g:last-of-type");
  }

  class View {
    constructor(id, style) {
      this.id = id;
      this.style = style;
      this.state = { track: [] };
    }

    px(x, y) {
      const [cx, cy, scale] = this.state.view;
      const w = this.style.size[0], h = this.style.size[1];
      return [(x - cx) * scale + w / 2, h / 2 - (y - cy) * scale];
    }

    mount(pose, name) {
      const [x, y, th] = pose;
      const [mx, my, myaw] = this.style.mounts[name];
      const c = Math.cos(th), s = Math.sin(th);
      return [x + c * mx - s * my, y + s * mx + c * my, th + myaw];
    }

    ray(start, length, colour, width) {
      const [x, y, yaw] = start;
      const [ax, ay] = this.px(x, y);
      const [bx, by] = this.px(x + length * Math.cos(yaw), y + length * Math.sin(yaw));
      return `<line x1="${f(ax)}" y1="${f(ay)}" x2="${f(bx)}" y2="${f(by)}" stroke="${colour}" stroke-width="${width}"/>`;
    }

    robot(pose, selected, label) {
      const st = this.style, [x, y, th] = pose, scale = this.state.view[2];
      const [px, py] = this.px(x, y);
      const [hx, hy] = this.px(x + st.radius * Math.cos(th), y + st.radius * Math.sin(th));
      const fill = selected ? st.robot_selected : st.robot_other;
      const text = label
        ? `<text x="${f(px)}" y="${f(py - st.radius * scale - 4)}" font-size="12" text-anchor="middle">${esc(label)}</text>`
        : "";
      return (
        `<circle cx="${f(px)}" cy="${f(py)}" r="${f(st.radius * scale)}" fill="${fill}" fill-opacity="0.85" ` +
        `stroke="${st.outline}" stroke-width="1.5"/>` +
        `<line x1="${f(px)}" y1="${f(py)}" x2="${f(hx)}" y2="${f(hy)}" stroke="${st.outline}" stroke-width="2"/>${text}`
      );
    }

    sensors() {
      const st = this.style, s = this.state, layers = new Set(s.layers), pose = s.pose, scale = s.view[2];
      const parts = [];
      if (layers.has("track") && s.track.length > 1) {
        const p = s.track.map(([x, y]) => this.px(x, y));
        parts.push(`<polyline points="${pts(p.map((q) => q[0]), p.map((q) => q[1]))}" fill="none" stroke="${st.track}" stroke-width="1.5"/>`);
      }
      if (layers.has("camera")) {
        const [cx, cy, cyaw] = this.mount(pose, "camera");
        const r = st.camera_range, half = st.camera_half_fov;
        const corners = [[cx, cy], [cx + r * Math.cos(cyaw + half), cy + r * Math.sin(cyaw + half)], [cx + r * Math.cos(cyaw - half), cy + r * Math.sin(cyaw - half)]].map(([x, y]) => this.px(x, y));
        parts.push(`<polygon points="${pts(corners.map((q) => q[0]), corners.map((q) => q[1]))}" fill="${st.camera}" fill-opacity="0.06" stroke="${st.camera}" stroke-opacity="0.5"/>`);
        for (const [sx, sy] of s.sightings || []) {
          const [px, py] = this.px(cx + sx * Math.cos(cyaw) - sy * Math.sin(cyaw), cy + sx * Math.sin(cyaw) + sy * Math.cos(cyaw));
          parts.push(`<circle cx="${f(px)}" cy="${f(py)}" r="${f(Math.max(0.12 * scale, 6))}" fill="none" stroke="${st.camera}" stroke-width="3"/>`);
        }
      }
      if (layers.has("lidar") && s.scan) {
        const [a0, inc, mm, stamp] = s.scan;
        const [lx, ly, lyaw] = this.mount(pose, "laser");
        const xs = [], ys = [];
        mm.forEach((r, i) => {
          const d = r < 0 ? st.lidar_max : r / 1000, a = lyaw + a0 + inc * i;
          const [px, py] = this.px(lx + d * Math.cos(a), ly + d * Math.sin(a));
          xs.push(px);
          ys.push(py);
        });
        parts.push(`<polyline class="lidar" data-stamp="${stamp}" points="${pts(xs, ys)}" fill="none" stroke="${st.lidar}" stroke-width="2" stroke-opacity="0.9"/>`);
      }
      if (layers.has("sonar") && s.sonar) {
        st.sonar_names.forEach((name, i) => {
          const v = s.sonar[i];
          if (v !== null && v !== undefined) parts.push(this.ray(this.mount(pose, `sonar_${name}`), v < 0 ? st.sonar_max : v, st.sonar, 2));
        });
      }
      if (layers.has("wall") && s.wall) parts.push(this.ray(this.mount(pose, "wall_ir"), st.ir_range, st.wall, 4));
      if (layers.has("bump") && s.bumps) {
        ["left", "right"].forEach((side, i) => {
          if (!s.bumps[i]) return;
          const [x, y, th] = pose, r = st.radius * 1.08, bearing = th + st.mounts[`bump_${side}`][2];
          const xs = [], ys = [];
          for (let k = 0; k < 9; k++) {
            const a = bearing - Math.PI / 4 + (k * Math.PI) / 16;
            const [px, py] = this.px(x + r * Math.cos(a), y + r * Math.sin(a));
            xs.push(px);
            ys.push(py);
          }
          parts.push(`<polyline class="bump" points="${pts(xs, ys)}" fill="none" stroke="${st.bump}" stroke-width="5"/>`);
        });
      }
      if (layers.has("cliff") && s.cliffs) {
        st.cliff_names.forEach((name, i) => {
          if (!s.cliffs[i]) return;
          const [x, y] = this.mount(pose, `cliff_${name}`);
          const [px, py] = this.px(x, y);
          parts.push(`<text x="${f(px)}" y="${f(py + 7)}" font-size="20" text-anchor="middle" fill="${st.cliff}">*</text>`);
        });
      }
      return parts.join("");
    }

    update(msg) {
      const s = this.state;
      for (const key of ["view", "layers", "pose", "label", "others", "scan", "sonar", "wall", "bumps", "cliffs", "sightings"]) {
        if (key in msg) s[key] = msg[key];
      }
      if (msg.track_reset) s.track = [];
      if (msg.track) {
        s.track.push(...msg.track);
        if (s.track.length > this.style.track_points) s.track.splice(0, s.track.length - this.style.track_points);
      }
      this.draw();
    }

    draw() {
      const s = this.state, group = layerGroup(this.id);
      if (!group || !s.pose || !s.view) return;
      const [cx, cy, scale] = s.view;
      const parts = [`<g class="view" data-centre-x="${cx}" data-centre-y="${cy}" data-scale="${scale}"/>`];
      for (const [ns, x, y, th] of s.others || []) parts.push(this.robot([x, y, th], false, ns));
      parts.push(this.sensors());
      parts.push(this.robot(s.pose, true, s.label));
      group.innerHTML = parts.join("");
    }
  }

  return {
    init(id, style) {
      views[id] = new View(id, style);
    },
    update(id, msg) {
      const view = views[id];
      if (view) view.update(msg);
    },
    clear(id) {
      const group = layerGroup(id);
      if (group) group.innerHTML = "";
      if (views[id]) views[id].state = { track: [] };
    },
  };
})();
