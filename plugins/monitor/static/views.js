// The camera image with the markers the tracker found, and the world seen from above.

export class CameraView {
  constructor(canvas, caption, empty) {
    this.canvas = canvas;
    this.caption = caption;
    this.empty = empty;
    this.ctx = canvas.getContext("2d");
    this.frames = 0;
  }

  // header: {t, tick, detections: {width, height, frame, markers: [{id, role, corners, axes}]}}
  async show(header, jpegBytes) {
    const bitmap = await createImageBitmap(new Blob([jpegBytes], { type: "image/jpeg" }));
    const { canvas, ctx } = this;
    if (canvas.width !== bitmap.width || canvas.height !== bitmap.height) {
      canvas.width = bitmap.width;
      canvas.height = bitmap.height;
    }
    ctx.drawImage(bitmap, 0, 0);
    bitmap.close();
    const found = header.detections || { markers: [] };
    for (const m of found.markers) this._marker(m);
    this.frames += 1;
    this.empty.hidden = true;
    const n = found.markers.length;
    this.caption.textContent = `frame ${found.frame} · t ${Number(header.t).toFixed(2)} s · ` +
      (found.looked ? `${n} marker${n === 1 ? "" : "s"}` : "not searched");
    this.canvas.dataset.frames = String(this.frames);
    this.canvas.dataset.t = String(header.t);
  }

  clear(text) {
    this.ctx.clearRect(0, 0, this.canvas.width, this.canvas.height);
    this.empty.textContent = text;
    this.empty.hidden = false;
    this.caption.textContent = "";
  }

  _marker(m) {
    const ctx = this.ctx;
    const c = m.corners;
    ctx.lineWidth = 2.5;
    ctx.strokeStyle = "#33ff77";
    ctx.fillStyle = "rgba(51,255,119,0.15)";
    ctx.beginPath();
    ctx.moveTo(c[0][0], c[0][1]);
    for (let i = 1; i < c.length; i++) ctx.lineTo(c[i][0], c[i][1]);
    ctx.closePath();
    ctx.fill();
    ctx.stroke();
    ctx.fillStyle = "#ff3366";
    ctx.fillRect(c[0][0] - 3, c[0][1] - 3, 6, 6);
    if (m.axes) {
      const [o, x, y, z] = m.axes;
      for (const [p, color] of [[x, "#ff4040"], [y, "#40ff40"], [z, "#4090ff"]]) {
        ctx.strokeStyle = color;
        ctx.lineWidth = 3;
        ctx.beginPath();
        ctx.moveTo(o[0], o[1]);
        ctx.lineTo(p[0], p[1]);
        ctx.stroke();
      }
    }
    const label = `${m.id}${m.role && m.role !== "unknown" ? " " + m.role : ""}`;
    ctx.font = "bold 15px system-ui, sans-serif";
    const w = ctx.measureText(label).width + 10;
    const lx = Math.min(...c.map((p) => p[0])), ly = Math.min(...c.map((p) => p[1])) - 8;
    ctx.fillStyle = "rgba(0,0,0,0.7)";
    ctx.fillRect(lx, ly - 16, w, 20);
    ctx.fillStyle = "#ffffff";
    ctx.fillText(label, lx + 5, ly - 1);
  }
}

function yawOf(pose) {
  const [, , , qx, qy, qz, qw] = pose;
  return Math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz));
}

function css(color, alpha = 1) {
  const [r, g, b] = color.map((v) => Math.round(v * 255));
  return `rgba(${r},${g},${b},${alpha})`;
}

export class OverheadView {
  constructor(canvas, caption, empty) {
    this.canvas = canvas;
    this.caption = caption;
    this.empty = empty;
    this.ctx = canvas.getContext("2d");
    this.bounds = null;
  }

  _frame(scene) {
    const table = scene.objects.find((o) => o.kind === "table");
    let x0, x1, y0, y1;
    if (table) {
      x0 = table.pose[0] - table.size[0] / 2; x1 = table.pose[0] + table.size[0] / 2;
      y0 = table.pose[1] - table.size[1] / 2; y1 = table.pose[1] + table.size[1] / 2;
    } else {
      const xs = [0], ys = [0];
      for (const o of scene.objects) { xs.push(o.pose[0]); ys.push(o.pose[1]); }
      if (scene.arm) for (const b of scene.arm.boxes) { xs.push(b[0]); ys.push(b[1]); }
      x0 = Math.min(...xs) - 150; x1 = Math.max(...xs) + 150;
      y0 = Math.min(...ys) - 150; y1 = Math.max(...ys) + 150;
    }
    const { width, height } = this.canvas;
    const s = Math.min((width - 24) / (x1 - x0), (height - 24) / (y1 - y0));
    const ox = (width - s * (x1 - x0)) / 2, oy = (height - s * (y1 - y0)) / 2;
    // x to the right, y up.
    this.px = (x, y) => [ox + (x - x0) * s, height - oy - (y - y0) * s];
    this.scale = s;
  }

  _box(pose, size, fill, stroke) {
    const ctx = this.ctx;
    const [cx, cy] = this.px(pose[0], pose[1]);
    ctx.save();
    ctx.translate(cx, cy);
    ctx.rotate(-yawOf(pose));
    const w = size[0] * this.scale, h = size[1] * this.scale;
    ctx.fillStyle = fill;
    ctx.fillRect(-w / 2, -h / 2, w, h);
    if (stroke) { ctx.strokeStyle = stroke; ctx.lineWidth = 1; ctx.strokeRect(-w / 2, -h / 2, w, h); }
    ctx.restore();
  }

  _line(points, color, width, dash = [], close = false) {
    if (!points || points.length < 2) return;
    const ctx = this.ctx;
    ctx.save();
    ctx.strokeStyle = color;
    ctx.lineWidth = width;
    ctx.setLineDash(dash);
    ctx.beginPath();
    points.forEach((p, i) => { const [x, y] = this.px(p[0], p[1]); if (i) ctx.lineTo(x, y); else ctx.moveTo(x, y); });
    if (close) ctx.closePath();
    ctx.stroke();
    ctx.restore();
  }

  show(scene) {
    if (!scene) return;
    const { ctx, canvas } = this;
    this._frame(scene);
    ctx.fillStyle = "#0a0d12";
    ctx.fillRect(0, 0, canvas.width, canvas.height);
    const objects = [...scene.objects].sort((a, b) => (a.pose[2] + a.size[2] / 2) - (b.pose[2] + b.size[2] / 2));
    for (const o of objects) {
      if (o.kind === "table") { this._box(o.pose, o.size, "#c9b48f", "#8d7a58"); continue; }
      if (o.route && o.route.length > 1) this._line(o.route, "rgba(200,200,200,0.6)", 1.2, [5, 4]);
      this._box(o.pose, o.size, css(o.color, o.held ? 0.75 : 1), o.held ? "#ff3b3b" : "rgba(0,0,0,0.6)");
    }
    this._line(scene.trail, "rgba(47,208,224,0.9)", 1.5);
    this._line(scene.path, "#ff4fd8", 3);
    if (scene.camera && scene.camera.footprint && scene.camera.footprint.length) {
      this._line(scene.camera.footprint, "#ffd400", 2, [], true);
    }
    if (scene.arm) {
      scene.arm.boxes.forEach((b, i) => this._box(b, scene.arm.sizes[i], "rgba(110,114,124,0.85)", "#1b1d22"));
      const [tx, ty] = this.px(scene.arm.tool[0], scene.arm.tool[1]);
      ctx.beginPath();
      ctx.arc(tx, ty, 5, 0, 2 * Math.PI);
      ctx.fillStyle = scene.arm.suction ? "#ff3b3b" : "#ffffff";
      ctx.fill();
    }
    ctx.font = "12px system-ui, sans-serif";
    for (const o of objects) {
      if (o.kind === "table") continue;
      const [x, y] = this.px(o.pose[0], o.pose[1]);
      const label = o.marker !== null && o.marker !== undefined ? `${o.name} #${o.marker}` : o.name;
      ctx.fillStyle = "rgba(0,0,0,0.55)";
      const w = ctx.measureText(label).width + 6;
      ctx.fillRect(x - w / 2, y - 24, w, 15);
      ctx.fillStyle = "#fff";
      ctx.fillText(label, x - w / 2 + 3, y - 12);
    }
    const [bx, by] = this.px(0, 0);
    ctx.strokeStyle = "#ff5050"; ctx.lineWidth = 2;
    ctx.beginPath(); ctx.moveTo(bx, by); ctx.lineTo(bx + 30, by); ctx.stroke();
    ctx.strokeStyle = "#50ff50";
    ctx.beginPath(); ctx.moveTo(bx, by); ctx.lineTo(bx, by - 30); ctx.stroke();
    this.empty.hidden = true;
    this.caption.textContent = `t ${Number(scene.t).toFixed(2)} s` + (scene.arm ? " · arm from its joint readings" : "");
  }
}
